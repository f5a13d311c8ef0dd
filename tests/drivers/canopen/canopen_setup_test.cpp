// open_canopen_drives: configuration problems are refused before the bus is touched; a
// missing interface is a CanSetupError naming it. (Booting over SocketCAN: tests/hil.)
#include "drivers/canopen_setup.hpp"

#include <gtest/gtest.h>

#include <string>

#include "common/config_error.hpp"

namespace dualv::drivers {
namespace {

TEST(CanopenSetup, SyncPeriodOtherThanControlPeriodRefused) {
  CanopenSetupOptions o;
  o.interface = "dualv-no-such-can0";
  o.control_period_s = 0.002;
  EXPECT_THROW((void)open_canopen_drives(default_can_config(), o), ConfigError);
}

TEST(CanopenSetup, BusLoadRefusedBeforeOpening) {
  CanConfig c = default_can_config();
  c.sync_period_ns = 500'000;
  CanopenSetupOptions o;
  o.interface = "dualv-no-such-can0";
  EXPECT_THROW((void)open_canopen_drives(c, o), ConfigError);
}

TEST(CanopenSetup, MissingInterfaceNamed) {
  CanopenSetupOptions o;
  o.interface = "dualvx9";
  try {
    (void)open_canopen_drives(default_can_config(), o);
    FAIL();
  } catch (const CanSetupError& e) {
    EXPECT_NE(std::string(e.what()).find("dualvx9"), std::string::npos) << e.what();
  }
}

TEST(CanopenSetup, MasterConfigFromTheSection) {
  CanConfig c = default_can_config();
  c.master_node_id = 100;
  const canopen::MasterConfig m = master_config(c);
  EXPECT_EQ(m.node_id, 100);
  EXPECT_EQ(m.sdo_timeout_ns, c.sdo_timeout_ns);
  EXPECT_EQ(m.heartbeat_period_ns, c.master_heartbeat_period_ns);
}

}  // namespace
}  // namespace dualv::drivers
