// The master's scripted slave (fake_slave.hpp) on its PDOs, frame by frame: the PDO engine
// mapped from the records the master writes, synchronous RPDOs acting at the next SYNC (CiA
// 301 7.3.2), an RPDO shorter than its mapping (CiA 301 7.2.2.2, EMCY 8210h) and the broadcast
// layout's mappings (configure_pdos). Expected frames written by hand from CiA 301 / 402.
#include "fake_slave.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "drivers/canopen_config.hpp"

namespace dualv::drivers {
namespace {

using test::FakeSlave;

struct FakeSlavePdos : ::testing::Test {
  FakeSlavePdos() : hub(2, 64), slave(hub.endpoint(1), 3) {}
  // The master's side: sends `text` (candump's ID#DATA), lets the slave answer, returns its
  // answers as text.
  std::vector<std::string> send(const std::string& text) {
    (void)master().send(test::from_text(text));
    slave.step();
    std::vector<std::string> out;
    for (const fw::CanFrame& f : test::drain(master())) out.push_back(test::to_text(f));
    return out;
  }
  InProcessBus& master() { return hub.endpoint(0); }
  void start() { EXPECT_EQ(send("000#0103").size(), 1u); }  // NMT start node 3: a heartbeat

  InProcessHub hub;
  FakeSlave slave;
};

using Frames = std::vector<std::string>;

TEST_F(FakeSlavePdos, SynchronousRpdoActsAtTheNextSync) {
  start();
  // RPDO1 (power-on mapping = the master's: controlword 6040h, target torque 6071h; type 1):
  // shutdown (0006h), 20 per mille. Nothing acts before the SYNC.
  EXPECT_EQ(send("203#06001400"), Frames{});
  EXPECT_EQ(slave.cia, fw::Cia402State::kSwitchOnDisabled);
  EXPECT_EQ(slave.target_torque, 0);
  // At the SYNC, TPDO1 (statusword, position) is sampled before the RPDO acts: Switch on
  // disabled = 0040h with remote (bit 9) = 0240h, position 0.
  slave.position = 0x01020304;
  EXPECT_EQ(send("080#"), Frames{"183#400204030201"});
  EXPECT_EQ(slave.cia, fw::Cia402State::kReadyToSwitchOn);
  EXPECT_EQ(slave.target_torque, 20);
  EXPECT_EQ(slave.controlwords, std::vector<std::uint16_t>{0x0006});
  // The next SYNC's TPDO1 shows it: Ready to switch on = 0021h, remote 0200h.
  EXPECT_EQ(send("080#"), Frames{"183#210204030201"});
}

TEST_F(FakeSlavePdos, NoPdosOutsideOperational) {
  EXPECT_EQ(send("203#06001400"), Frames{});  // Pre-operational
  EXPECT_EQ(send("080#"), Frames{});
  start();
  EXPECT_EQ(send("080#"), Frames{"183#400200000000"});
  EXPECT_TRUE(slave.controlwords.empty());  // the Pre-operational RPDO was not kept
}

TEST_F(FakeSlavePdos, ShortRpdoIsNotProcessedAndRaisesEmcy8210h) {
  start();
  // 2 bytes for a 4-byte mapping: EMCY 8210h, error register generic + communication (11h).
  EXPECT_EQ(send("203#0600"), Frames{"083#1082110000000000"});
  EXPECT_EQ(send("203#0600"), Frames{});  // still the same condition: no second EMCY
  EXPECT_EQ(send("080#"), Frames{"183#400200000000"});
  EXPECT_TRUE(slave.controlwords.empty());
  // A correct one: the condition is gone, EMCY 0000h with error register 00h.
  EXPECT_EQ(send("203#06000000"), Frames{"083#0000000000000000"});
  EXPECT_EQ(slave.error_register(), 0);
}

TEST_F(FakeSlavePdos, BroadcastLayoutAsTheMasterMapsIt) {
  CanConfig config = default_can_config();
  config.bus_layout = fw::BusLayout::kBroadcast;
  ASSERT_EQ(config.drives.size(), 4u);
  slave.configure_pdos(config, 2);  // node 3 is drive 2: bytes 4..5 of the torque frame
  start();
  // The controlword RPDO1 (type 255) acts on reception.
  EXPECT_EQ(send("203#0600"), Frames{});
  EXPECT_EQ(slave.cia, fw::Cia402State::kReadyToSwitchOn);
  // The torque frame (type 1): 20, 40, -20, 10 per mille; this drive's -20 at the SYNC.
  EXPECT_EQ(send("200#14002800ECFF0A00"), Frames{});
  EXPECT_EQ(slave.target_torque, 0);
  slave.position = -2;
  // TPDO1 = position alone, TPDO2 = digital inputs 60FDh and TPDO3 = statusword (both event
  // driven: the first SYNC sends them).
  EXPECT_EQ(send("080#"), (Frames{"183#FEFFFFFF", "283#00000000", "383#2102"}));
  EXPECT_EQ(slave.target_torque, -20);
  // Statusword unchanged: TPDO3 is not sent again.
  EXPECT_EQ(send("080#"), Frames{"183#FEFFFFFF"});
}

TEST_F(FakeSlavePdos, ConfigurePdosNamesARefusedWrite) {
  // The fd layout maps 16 bytes into RPDO2 (1601h): a classic drive refuses the count with
  // 06040042h (mapping longer than the PDO, CiA 301 7.5.2.36).
  CanConfig config = default_can_config();
  config.bus_layout = fw::BusLayout::kFd;
  try {
    slave.configure_pdos(config, 0);
    FAIL() << "no refusal";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("1601h sub0 = 00000008h"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(": 06040042h"), std::string::npos) << e.what();
  }
}

TEST_F(FakeSlavePdos, MappingChangesFollowCiA301) {
  // CiA 301 7.5.2.36: a valid PDO's mapping cannot change (06010000h unsupported access),
  // hence the master's order (drivers/canopen/boot.cpp add_pdo): COB-ID invalid first.
  start();
  EXPECT_EQ(send("603#2F00160000000000"), Frames{"583#8000160000000106"});  // RPDO1 valid
  EXPECT_EQ(send("603#2300140103020080"), Frames{"583#6000140100000000"});  // invalid
  EXPECT_EQ(send("603#2F00160000000000"), Frames{"583#6000160000000000"});  // count 0
  // A mapping of an object that does not exist: 06020000h at sub0 = 1.
  EXPECT_EQ(send("603#2300160110000120"), Frames{"583#6000160100000000"});
  EXPECT_EQ(send("603#2F00160001000000"), Frames{"583#8000160000000206"});
}

}  // namespace
}  // namespace dualv::drivers
