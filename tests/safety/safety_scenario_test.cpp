// Closed-loop fault scenarios: the paper program on the in-process simulated Dual-V
// (SimActuatorSet + Plant, simulated time), with the safety filter integrated in the
// control cycle. Each fault is injected mid-program; the test checks detection within 2
// cycles (or the configured timeout), the configured reaction within its time, the torque
// written to the drives never above the limit, and the event in the fault log.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "control/loop/control_cycle.hpp"
#include "control/trajectory/program.hpp"
#include "paper_fixture.hpp"
#include "safety/fault_injector.hpp"
#include "sim/plant.hpp"
#include "sim/sim_actuator_set.hpp"

namespace dualv::safety::test {
namespace {

using control::CyclePhase;
using control::CycleStatus;
using drivers::DriveRequest;

struct Rig {
  explicit Rig(const SafetyConfig& safety = robot().safety)
      : plant(robot().model, robot().plant),
        sim((plant.reset(robot().model.home), plant)),
        io(sim),
        cycle(robot().model, robot().control, {robot().period(), 2.0, safety}) {}
  void start() { cycle.start(io, paper(), robot().trajectory.rebase); }
  CycleStatus step() {
    const CycleStatus s = cycle.step(io, rec);
    plant.advance(robot().period());
    FaultEvent e;
    while (cycle.safety().log().try_pop(e)) events.push_back(e);
    return s;
  }
  // Runs until the program is well into its shapes (t >= t_run) without any stop.
  void run_until(double t_run) {
    for (int k = 0; k < 20000 && !(rec.phase == CyclePhase::kRunning && rec.t >= t_run); ++k)
      ASSERT_EQ(step(), CycleStatus::kOk) << "cycle " << rec.cycle;
    ASSERT_EQ(rec.phase, CyclePhase::kRunning);
  }
  const FaultEvent* find(Fault f) const {
    for (const auto& e : events)
      if (e.kind == EventKind::kFault && e.fault == f) return &e;
    return nullptr;
  }
  const FaultEvent* find(EventKind k) const {
    for (const auto& e : events)
      if (e.kind == k) return &e;
    return nullptr;
  }
  double joint_speed() const { return plant.output().q_dot.cwiseAbs().maxCoeff(); }

  sim::Plant plant;
  sim::SimActuatorSet sim;
  FaultInjector io;
  control::ControlCycle cycle;
  control::CycleRecord rec;
  std::vector<FaultEvent> events;
};

// Steps until the first cycle with a DriveRequest::kDisable; returns cycles stepped.
int cycles_until_disabled(Rig& r, int limit) {
  for (int k = 1; k <= limit; ++k) {
    r.step();
    if (r.rec.command.request == DriveRequest::kDisable) return k;
  }
  return -1;
}

TEST(SafetyScenario, PaperProgramRunsWithoutAnySafetyEvent) {
  Rig r;
  r.start();
  int bad = 0;
  for (int k = 0; k < 9000; ++k)
    if (r.step() != CycleStatus::kOk) ++bad;
  EXPECT_EQ(bad, 0);
  EXPECT_EQ(r.rec.phase, CyclePhase::kHolding);
  ASSERT_EQ(r.events.size(), 1u) << describe(r.events.back());
  EXPECT_EQ(r.events[0].kind, EventKind::kArmed);
  EXPECT_LE(r.io.max_torque(), robot().safety.torque.max);
}

TEST(SafetyScenario, EstopDuringTheProgramIsSs1ToStandstillThenDisable) {
  Rig r;
  r.start();
  r.run_until(2.0);
  ASSERT_GT(r.joint_speed(), 0.1);  // it is moving
  const std::int64_t injected = r.rec.cycle + 1;
  r.cycle.safety().request_stop(StopSource::kLcm);
  EXPECT_EQ(r.step(), CycleStatus::kSafetyStop);
  const FaultEvent* e = r.find(Fault::kEstopLcm);
  ASSERT_NE(e, nullptr);
  EXPECT_LE(e->cycle - injected, 2);
  EXPECT_EQ(r.rec.safety.state, SafetyState::kSs1);
  EXPECT_EQ(r.rec.command.request, DriveRequest::kHold);  // braking under power
  const int to_sto = cycles_until_disabled(r, 5000);
  ASSERT_GT(to_sto, 0);
  EXPECT_LE(to_sto + 1, r.cycle.safety().limits().ss1_max);
  EXPECT_NE(r.find(EventKind::kStopReached), nullptr);
  EXPECT_EQ(r.find(Fault::kStopTimeout), nullptr);
  EXPECT_LT(r.joint_speed(), 2 * robot().safety.ss1.standstill_velocity);
  EXPECT_LE(r.io.max_torque(), robot().safety.torque.max);
  // Stays disabled, the program is abandoned.
  for (int k = 0; k < 500; ++k) {
    r.step();
    ASSERT_EQ(r.rec.command.request, DriveRequest::kDisable);
    ASSERT_EQ(r.rec.phase, CyclePhase::kStopped);
  }
}

TEST(SafetyScenario, DriveFaultIsStoAtOnce) {
  Rig r;
  r.start();
  r.run_until(1.5);
  r.sim.inject_fault(2, 0x2310);  // EMCY: continuous over-current
  r.step();
  EXPECT_EQ(r.rec.command.request, DriveRequest::kDisable);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(r.rec.command.torque[i], 0.0);
  const FaultEvent* e = r.find(Fault::kDriveFault);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->reaction, Reaction::kSto);
  EXPECT_EQ(e->drive, 2);
  EXPECT_EQ(e->value, 0x2310);
  for (int i = 0; i < 4; ++i) EXPECT_NE(r.sim.state(i), drivers::DriveState::kEnabled);
}

TEST(SafetyScenario, DriveLostStopsAllFour) {
  Rig r;
  r.start();
  r.run_until(1.5);
  r.sim.set_offline(1, true);
  r.step();
  EXPECT_EQ(r.rec.command.request, DriveRequest::kDisable);
  ASSERT_NE(r.find(Fault::kDriveLost), nullptr);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NE(r.sim.state(i), drivers::DriveState::kEnabled) << i;
    EXPECT_EQ(r.plant.output().tau_command[i], 0.0) << i;
  }
}

TEST(SafetyScenario, HardwiredEstopCircuitIsSto) {
  Rig r;
  r.start();
  r.run_until(1.0);
  r.sim.set_stop_input(true);
  r.step();
  EXPECT_EQ(r.rec.command.request, DriveRequest::kDisable);
  ASSERT_NE(r.find(Fault::kEstopInput), nullptr);
}

TEST(SafetyScenario, EncoderJumpIsSto) {
  Rig r;
  r.start();
  r.run_until(1.2);
  r.io.jump_encoder(3, 0.2);
  r.step();
  EXPECT_EQ(r.rec.command.request, DriveRequest::kDisable);
  const FaultEvent* e = r.find(Fault::kEncoderJump);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->drive, 3);
}

TEST(SafetyScenario, StaleFeedbackAtTheConfiguredCycles) {
  Rig r;
  r.start();
  r.run_until(1.2);
  r.io.freeze_feedback(0, true);
  const int k = robot().safety.watchdogs.stale_feedback_cycles;
  for (int c = 1; c < k; ++c) {
    r.step();
    EXPECT_NE(r.rec.command.request, DriveRequest::kDisable) << c;
  }
  r.step();
  EXPECT_EQ(r.rec.command.request, DriveRequest::kDisable);
  ASSERT_NE(r.find(Fault::kStaleFeedback), nullptr);
  EXPECT_EQ(r.find(Fault::kStaleFeedback)->latency_cycles, k - 1);
}

void ten_times(void* ctx, std::int64_t cycle, drivers::ActuatorCommand& c) noexcept {
  const auto from = *static_cast<std::int64_t*>(ctx);
  if (cycle >= from)
    for (int i = 0; i < c.n; ++i) c.torque[i] = (i % 2 ? -10.0 : 10.0) * 60.0;
}

TEST(SafetyScenario, ControllerCommandingTenTimesTheLimitNeverReachesTheDrives) {
  Rig r;
  r.start();
  r.run_until(1.0);
  std::int64_t from = r.rec.cycle + 1;
  r.cycle.set_command_hook(ten_times, &from);
  r.io.reset_max_torque();
  r.step();
  const FaultEvent* e = r.find(Fault::kTorqueLimit);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->cycle, from);  // detected in the cycle it was commanded
  EXPECT_EQ(r.rec.safety.state, SafetyState::kSs1);
  for (int k = 0; k < 2000; ++k) r.step();
  EXPECT_LE(r.io.max_torque(), robot().safety.torque.max);
  EXPECT_LE(r.io.max_torque(), robot().safety.ss1.max_torque + 1e-9);  // never more than a brake
  EXPECT_EQ(r.rec.command.request, DriveRequest::kDisable);
  EXPECT_LT(r.joint_speed(), 0.2);
}

TEST(SafetyScenario, ResetNeedsAllCausesClearedAndNeverRestartsMotion) {
  Rig r;
  r.start();
  r.run_until(1.0);
  r.sim.set_stop_input(true);
  r.cycle.safety().request_stop(StopSource::kCli);
  r.step();
  for (int k = 0; k < 300; ++k) r.step();       // coasts to rest (friction)
  EXPECT_THROW(r.start(), std::runtime_error);  // latched: no start
  r.cycle.safety().request_reset();
  for (int k = 0; k < 50; ++k) r.step();
  ASSERT_NE(r.find(EventKind::kResetRefused), nullptr);  // the circuit is still open
  EXPECT_EQ(r.rec.safety.state, SafetyState::kSto);
  r.sim.set_stop_input(false);
  r.cycle.safety().request_reset();
  r.step();
  ASSERT_NE(r.find(EventKind::kResetAccepted), nullptr);
  EXPECT_EQ(r.rec.safety.state, SafetyState::kDisabled);
  // After STO the mechanism coasts (stop category 0); the reset must not add any energy.
  double energy = r.plant.kinetic_energy();
  for (int k = 0; k < 2000; ++k) {
    r.step();
    ASSERT_EQ(r.rec.command.request, DriveRequest::kDisable);
    ASSERT_EQ(r.rec.phase, CyclePhase::kStopped);
    ASSERT_LT(r.plant.output().tau_applied.cwiseAbs().maxCoeff(), 1e-9) << k;  // current-loop decay
    const double e = r.plant.kinetic_energy();
    ASSERT_LE(e, energy + 1e-12) << k;
    energy = e;
  }
  for (int i = 0; i < 4; ++i) EXPECT_NE(r.sim.state(i), drivers::DriveState::kEnabled);
  // A new start does: from the actual pose, enable, run.
  r.start();
  r.run_until(0.5);
  EXPECT_EQ(r.rec.safety.state, SafetyState::kOperational);
}

}  // namespace
}  // namespace dualv::safety::test
