// The CiA 402 slave part (sim/canopen/cia402_slave.hpp): controlwords and statuswords as
// numbers written by hand from CiA 402-2 (table 29 commands: shutdown 0006h, switch on
// 0007h, enable operation 000Fh, disable voltage 0000h, quick stop 0002h, fault reset bit 7;
// statusword patterns 6.3.2: Switch on disabled 0040h, Ready to switch on 0021h, Switched on
// 0023h, Operation enabled 0027h, Quick stop active 0007h, Fault 0008h; + remote 0200h,
// + voltage enabled 0010h in Switched on / Operation enabled / Quick stop active).
#include "sim/canopen/cia402_slave.hpp"

#include <gtest/gtest.h>

namespace dualv::sim::canopen {
namespace {

using fw::Cia402State;
using E = ControlwordEffect;

constexpr std::int16_t kQuickStopRamp = 2;  // 605Ah 2: ramp, then Switch on disabled
constexpr std::int16_t kDisableDrive = 0;
constexpr std::int16_t kQuickStopRampStay = 6;

struct Drive : ::testing::Test {
  Cia402Slave cia;
  E cw(std::uint16_t w, std::int16_t qs = kQuickStopRamp, bool sto = false, bool cause = false) {
    return cia.on_controlword(w, qs, sto, cause);
  }
  void enable() {
    ASSERT_EQ(cw(0x0006), E::kTransition);
    ASSERT_EQ(cw(0x0007), E::kTransition);
    ASSERT_EQ(cw(0x000F), E::kTransition);
  }
};

TEST_F(Drive, PowerOnLandsInSwitchOnDisabled) {
  cia.power_on();
  EXPECT_EQ(cia.state(), Cia402State::kSwitchOnDisabled);
  EXPECT_EQ(cia.last_transition(), 1);
  EXPECT_EQ(cia.statusword(), 0x0240);
}

TEST_F(Drive, EnableSequenceWithItsStatuswords) {
  cia.power_on();
  EXPECT_EQ(cw(0x0006), E::kTransition);
  EXPECT_EQ(cia.last_transition(), 2);
  EXPECT_EQ(cia.statusword(), 0x0221);
  EXPECT_EQ(cw(0x0007), E::kTransition);
  EXPECT_EQ(cia.last_transition(), 3);
  EXPECT_EQ(cia.statusword(), 0x0233);
  EXPECT_EQ(cw(0x000F), E::kTransition);
  EXPECT_EQ(cia.last_transition(), 4);
  EXPECT_EQ(cia.statusword(), 0x0237);
  EXPECT_EQ(cia.statusword(0x1000), 0x1237);  // the application's bits on top
  EXPECT_EQ(cw(0x000F), E::kNone);            // no change: nothing
  EXPECT_EQ(cw(0x0007), E::kTransition);      // disable operation
  EXPECT_EQ(cia.last_transition(), 5);
  EXPECT_EQ(cw(0x0000), E::kTransition);  // disable voltage from Switched on
  EXPECT_EQ(cia.last_transition(), 10);
  EXPECT_EQ(cia.statusword(), 0x0240);
}

TEST_F(Drive, TheSafeTorqueOffCircuitRefusesTransition2) {
  cia.power_on();
  EXPECT_EQ(cw(0x0006, kQuickStopRamp, true), E::kNone);
  EXPECT_EQ(cia.state(), Cia402State::kSwitchOnDisabled);
}

TEST_F(Drive, QuickStopFollows605Ah) {
  cia.power_on();
  enable();
  EXPECT_EQ(cw(0x0002), E::kTransition);  // 11
  EXPECT_EQ(cia.state(), Cia402State::kQuickStopActive);
  EXPECT_EQ(cia.statusword(), 0x0217);
  cia.on_sync();  // 605Ah 1..4: stopped, then 12
  EXPECT_EQ(cia.state(), Cia402State::kSwitchOnDisabled);
  EXPECT_EQ(cia.last_transition(), 12);

  cw(0x0000);
  enable();
  cw(0x0002, kDisableDrive);  // 605Ah 0: Switch on disabled at once
  EXPECT_EQ(cia.state(), Cia402State::kSwitchOnDisabled);

  cw(0x0000);
  enable();
  cw(0x0002, kQuickStopRampStay);  // 605Ah 5..8: stays, and 16 may re-enable
  cia.on_sync();
  EXPECT_EQ(cia.state(), Cia402State::kQuickStopActive);
  EXPECT_EQ(cw(0x000F, kQuickStopRampStay), E::kTransition);
  EXPECT_EQ(cia.last_transition(), 16);
  EXPECT_EQ(cia.state(), Cia402State::kOperationEnabled);
}

TEST_F(Drive, FaultAndFaultResetOnTheRisingEdgeOfBit7) {
  cia.power_on();
  enable();
  EXPECT_TRUE(cia.fault());
  EXPECT_EQ(cia.state(), Cia402State::kFault);
  EXPECT_EQ(cia.last_transition(), 14);
  EXPECT_EQ(cia.statusword(), 0x0208);
  EXPECT_FALSE(cia.fault());        // already in Fault
  EXPECT_EQ(cw(0x000F), E::kNone);  // no command leaves Fault
  EXPECT_EQ(cw(0x0080, kQuickStopRamp, false, true), E::kFaultResetRefused);
  EXPECT_EQ(cw(0x0080), E::kNone);  // bit 7 still set: no edge
  EXPECT_EQ(cw(0x0000), E::kNone);
  EXPECT_EQ(cw(0x0080), E::kFaultReset);  // 0 -> 1
  EXPECT_EQ(cia.last_transition(), 15);
  EXPECT_EQ(cia.statusword(), 0x0240);
}

TEST_F(Drive, DisableVoltageFromEveryPowerState) {
  cia.power_on();
  EXPECT_FALSE(cia.disable_voltage());  // nothing to disable
  cw(0x0006);
  EXPECT_TRUE(cia.disable_voltage());
  EXPECT_EQ(cia.last_transition(), 7);
  enable();
  EXPECT_TRUE(cia.disable_voltage());
  EXPECT_EQ(cia.last_transition(), 9);
  enable();
  cia.quick_stop(kQuickStopRampStay);
  EXPECT_TRUE(cia.disable_voltage());
  EXPECT_EQ(cia.last_transition(), 12);
}

}  // namespace
}  // namespace dualv::sim::canopen
