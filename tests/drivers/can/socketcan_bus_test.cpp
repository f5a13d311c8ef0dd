// SocketCanBus set-up errors, on any host (with or without CAN in its kernel). Traffic over
// a real interface is tested in tests/hil/socketcan_hil_test.cpp (inside user-mode-linux).
#include "drivers/can/socketcan_bus.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

namespace dualv::drivers {
namespace {

using ::testing::HasSubstr;

std::string setup_error(const std::string& ifname) {
  SocketCanConfig cfg;
  cfg.interface = ifname;
  try {
    SocketCanBus bus(cfg);
  } catch (const CanSetupError& e) {
    return e.what();
  }
  return "";
}

TEST(SocketCanBusSetUp, MissingInterfaceNamesItAndSaysHowToCreateIt) {
  const std::string msg = setup_error("dualvnone7");
  EXPECT_THAT(msg, HasSubstr("'dualvnone7' does not exist"));
  EXPECT_THAT(msg, HasSubstr("ip link add dev dualvnone7 type vcan"));
  EXPECT_THAT(msg, HasSubstr("run_in_vcan.sh"));
}

TEST(SocketCanBusSetUp, BadNamesAreRefused) {
  EXPECT_THAT(setup_error(""), HasSubstr("empty or longer"));
  EXPECT_THAT(setup_error("averyveryverylongname0"), HasSubstr("empty or longer"));
}

TEST(SocketCanBusSetUp, NonCanInterfaceIsRefusedByName) {
  // "lo" exists everywhere: either the kernel has no CAN sockets or lo is not CAN.
  const std::string msg = setup_error("lo");
  EXPECT_THAT(msg, HasSubstr("'lo'"));
  EXPECT_FALSE(msg.empty());
}

}  // namespace
}  // namespace dualv::drivers
