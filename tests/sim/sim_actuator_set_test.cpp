// SimActuatorSet: drive states, what torque reaches the plant in each, feedback contents.
#include "sim/sim_actuator_set.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "firmware_if/cia402.hpp"
#include "tests/sim/sim_fixture.hpp"

namespace dualv::sim {
namespace {

using drivers::ActuatorCommand;
using drivers::ActuatorFeedback;
using drivers::DriveRequest;
using drivers::DriveState;
using drivers::IoStatus;

constexpr double kCycle = 1e-3;

class SimActuatorSetTest : public ::testing::Test {
 protected:
  SimActuatorSetTest() : plant_(test::dual_v(), PlantConfig::ideal()), set_(plant_) {}

  // One cycle: write `request` with torque `tau` on every drive, advance the plant.
  IoStatus cycle(DriveRequest request, double tau = 1.0) {
    ActuatorCommand c;
    c.n = 4;
    c.request = request;
    for (int i = 0; i < 4; ++i) c.torque[i] = tau;
    const IoStatus s = set_.write(c);
    plant_.advance(kCycle);
    return s;
  }
  double applied(int i) const { return plant_.output().tau_applied[i]; }

  Plant plant_;
  SimActuatorSet set_;
};

TEST_F(SimActuatorSetTest, StartsDisabledAndAppliesNoTorque) {
  EXPECT_EQ(set_.size(), 4);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(set_.state(i), DriveState::kDisabled);
  EXPECT_EQ(cycle(DriveRequest::kHold, 5.0), IoStatus::kOk);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(applied(i), 0.0);
}

TEST_F(SimActuatorSetTest, EnableAppliesZeroOnTheEnablingCycleThenFollows) {
  cycle(DriveRequest::kEnable, 2.0);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(set_.state(i), DriveState::kEnabled);
    EXPECT_EQ(applied(i), 0.0);  // no jump on enable
  }
  cycle(DriveRequest::kHold, 2.0);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(applied(i), 2.0);
  cycle(DriveRequest::kEnable, 3.0);  // enable while enabled: keeps following
  EXPECT_EQ(applied(0), 3.0);
}

TEST_F(SimActuatorSetTest, DisableTakesTorqueOffAtOnce) {
  cycle(DriveRequest::kEnable);
  cycle(DriveRequest::kHold, 2.0);
  cycle(DriveRequest::kDisable, 2.0);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(set_.state(i), DriveState::kDisabled);
    EXPECT_EQ(applied(i), 0.0);
  }
}

TEST_F(SimActuatorSetTest, QuickStopTakesTorqueOffAndReenablesThroughDisabled) {
  cycle(DriveRequest::kEnable);
  cycle(DriveRequest::kHold, 2.0);
  cycle(DriveRequest::kQuickStop, 2.0);
  EXPECT_EQ(set_.state(0), DriveState::kQuickStop);
  EXPECT_EQ(applied(0), 0.0);
  cycle(DriveRequest::kHold, 2.0);
  EXPECT_EQ(set_.state(0), DriveState::kQuickStop);
  EXPECT_EQ(applied(0), 0.0);
  cycle(DriveRequest::kEnable, 2.0);
  EXPECT_EQ(set_.state(0), DriveState::kDisabled);  // transition 12 first
  cycle(DriveRequest::kEnable, 2.0);
  EXPECT_EQ(set_.state(0), DriveState::kEnabled);
  EXPECT_EQ(applied(0), 0.0);
  cycle(DriveRequest::kHold, 2.0);
  EXPECT_EQ(applied(0), 2.0);
}

TEST_F(SimActuatorSetTest, QuickStopFromDisabledStaysDisabled) {
  cycle(DriveRequest::kQuickStop);
  EXPECT_EQ(set_.state(0), DriveState::kDisabled);
}

TEST_F(SimActuatorSetTest, InjectedFaultTakesTorqueOffUntilReset) {
  cycle(DriveRequest::kEnable);
  set_.write({4, {2.0, 2.0, 2.0, 2.0}, DriveRequest::kHold});
  set_.inject_fault(1, 0x2310);  // before the plant steps: torque off at once
  plant_.advance(kCycle);
  EXPECT_EQ(set_.state(1), DriveState::kFault);
  EXPECT_EQ(applied(1), 0.0);
  EXPECT_EQ(applied(0), 2.0);
  ActuatorFeedback fb;
  set_.read(fb);
  EXPECT_EQ(fb.drive[1].state, DriveState::kFault);
  EXPECT_EQ(fb.drive[1].last_emcy, 0x2310);
  cycle(DriveRequest::kEnable, 2.0);  // enable does not clear a fault
  EXPECT_EQ(set_.state(1), DriveState::kFault);
  EXPECT_EQ(applied(1), 0.0);
  cycle(DriveRequest::kDisable, 2.0);  // nor does disable
  EXPECT_EQ(set_.state(1), DriveState::kFault);
  cycle(DriveRequest::kFaultReset, 2.0);
  EXPECT_EQ(set_.state(1), DriveState::kDisabled);
  set_.read(fb);
  EXPECT_EQ(fb.drive[1].last_emcy, 0);
}

TEST_F(SimActuatorSetTest, OfflineDriveIsStaleAndComesBackDisabled) {
  cycle(DriveRequest::kEnable);
  set_.set_offline(2, true);
  ActuatorFeedback fb;
  EXPECT_EQ(set_.read(fb), IoStatus::kStale);
  EXPECT_FALSE(fb.drive[2].fresh);
  EXPECT_TRUE(fb.drive[0].fresh);
  EXPECT_EQ(fb.drive[2].state, DriveState::kOffline);
  EXPECT_EQ(cycle(DriveRequest::kHold, 2.0), IoStatus::kStale);
  EXPECT_EQ(applied(2), 0.0);
  EXPECT_EQ(applied(0), 2.0);
  set_.set_offline(2, false);
  EXPECT_EQ(set_.state(2), DriveState::kDisabled);
  EXPECT_EQ(set_.read(fb), IoStatus::kOk);
}

TEST_F(SimActuatorSetTest, StopInputActsLikeSto) {
  cycle(DriveRequest::kEnable);
  set_.set_stop_input(true);
  cycle(DriveRequest::kEnable, 2.0);
  EXPECT_EQ(set_.state(0), DriveState::kDisabled);
  EXPECT_EQ(applied(0), 0.0);
  ActuatorFeedback fb;
  set_.read(fb);
  EXPECT_TRUE(fb.drive[0].stop_input);
  set_.set_stop_input(false);
  cycle(DriveRequest::kEnable, 2.0);
  cycle(DriveRequest::kHold, 2.0);
  EXPECT_EQ(applied(0), 2.0);
}

TEST_F(SimActuatorSetTest, ReadReportsMeasuredPositionsEveryCycle) {
  ActuatorFeedback fb;
  ASSERT_EQ(set_.read(fb), IoStatus::kOk);
  EXPECT_EQ(fb.n, 4);
  for (int i = 0; i < 4; ++i) {
    EXPECT_TRUE(fb.drive[i].fresh);
    EXPECT_EQ(fb.drive[i].position, plant_.output().q_measured[i]);
  }
  cycle(DriveRequest::kEnable);
  cycle(DriveRequest::kHold, 3.0);
  const std::uint64_t before = fb.cycle;
  set_.read(fb);
  EXPECT_EQ(fb.cycle, before + 1);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(fb.drive[i].position, plant_.output().q_measured[i]);
    EXPECT_EQ(fb.drive[i].torque_actual, 3.0);
  }
  EXPECT_NE(fb.drive[0].position, 0.0);
}

TEST_F(SimActuatorSetTest, StatuswordDecodesToTheReportedState) {
  cycle(DriveRequest::kEnable);
  set_.inject_fault(3, 0x7305);
  ActuatorFeedback fb;
  set_.read(fb);
  const auto enabled = fw::decode_statusword(fb.drive[0].statusword);
  ASSERT_TRUE(enabled.ok());
  EXPECT_EQ(enabled.value().state, fw::Cia402State::kOperationEnabled);
  const auto fault = fw::decode_statusword(fb.drive[3].statusword);
  ASSERT_TRUE(fault.ok());
  EXPECT_EQ(fault.value().state, fw::Cia402State::kFault);
}

TEST_F(SimActuatorSetTest, WrongSizeIsRejectedWithTorqueOff) {
  cycle(DriveRequest::kEnable);
  cycle(DriveRequest::kHold, 2.0);
  ActuatorCommand c;
  c.n = 3;
  c.torque = {5.0, 5.0, 5.0};
  EXPECT_EQ(set_.write(c), IoStatus::kBusError);
  plant_.advance(kCycle);
  EXPECT_EQ(applied(0), 0.0);
  EXPECT_EQ(set_.rejected_writes(), 1u);
}

TEST_F(SimActuatorSetTest, NonFiniteTorqueIsRejectedWithTorqueOff) {
  cycle(DriveRequest::kEnable);
  EXPECT_EQ(cycle(DriveRequest::kHold, NAN), IoStatus::kBusError);
  EXPECT_EQ(applied(0), 0.0);
}

TEST(DriveState, Names) {
  EXPECT_STREQ(drivers::to_string(DriveState::kEnabled), "enabled");
  EXPECT_STREQ(drivers::to_string(DriveState::kQuickStop), "quick stop");
}

}  // namespace
}  // namespace dualv::sim
