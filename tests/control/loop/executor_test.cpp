// The one real-time loop (control/loop/executor.hpp) on a manual clock: every cycle is stepped
// by the test, the simulated Dual-V (sim/plant.hpp) advances one period after each, so every
// mode change, refusal and stop is checked at an exact cycle, deterministically.
#include "control/loop/executor.hpp"
#include "control/loop/loop_thread.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <thread>
#include <vector>

#include "safety/fault_injector.hpp"
#include "safety/fault_log.hpp"
#include "sim/plant.hpp"
#include "sim/sim_actuator_set.hpp"
#include "tests/safety/paper_fixture.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::control {
namespace {

using drivers::DriveRequest;
using drivers::DriveState;
using K = LoopEvent::Kind;
using safety::SafetyState;
using safety::test::paper;
using safety::test::robot;

// An actuator set that can be told to refuse enabling (its drives stay disabled) or to report
// a bus error: the causes of kEnableTimeout and kIoError.
class Gate final : public drivers::ActuatorSet {
 public:
  explicit Gate(drivers::ActuatorSet& inner) : inner_(inner) {}
  int size() const noexcept override { return inner_.size(); }
  drivers::IoStatus read(drivers::ActuatorFeedback& fb) noexcept override {
    const drivers::IoStatus s = inner_.read(fb);
    return bus_error ? drivers::IoStatus::kBusError : s;
  }
  drivers::IoStatus write(const drivers::ActuatorCommand& c) noexcept override {
    last = c;
    drivers::ActuatorCommand out = c;
    if (never_enable && out.request == DriveRequest::kEnable) out.request = DriveRequest::kHold;
    return inner_.write(out);
  }
  bool never_enable = false;
  bool bus_error = false;
  drivers::ActuatorCommand last{};

 private:
  drivers::ActuatorSet& inner_;
};

struct LoopRig {
  explicit LoopRig(IdleMode idle = IdleMode::kDisabled)
      : plant(robot().model, robot().plant),
        sim((plant.reset(robot().model.home), plant)),
        faults(sim),
        gate(faults),
        executor(robot().model, robot().control, config(idle), gate) {}

  static ExecutorConfig config(IdleMode idle) {
    ExecutorConfig c;
    c.cycle = {robot().period(), 2.0, robot().safety};
    c.idle = idle;
    return c;
  }

  // One cycle of the loop, then one period of the mechanism.
  CycleResult step() {
    CycleInfo info;
    info.cycle = cycle++;
    info.period_ns = robot().loop.period_ns;
    info.release_ns = info.wake_ns = info.cycle * info.period_ns;
    const CycleResult r = executor.step(info);
    plant.advance(robot().period());
    LoopEvent e;
    while (executor.poll_event(e)) events.push_back(e);
    safety::FaultEvent f;
    while (executor.safety().log().try_pop(f)) faults_logged.push_back(f);
    executor.collect();
    max_torque = std::max(max_torque, executor.record().command.torque[0]);
    return r;
  }
  void steps(int n) {
    for (int k = 0; k < n; ++k) step();
  }
  std::uint64_t start_paper(std::uint64_t epoch) {
    auto ref = executor.prepare_program(paper(), robot().trajectory.rebase, epoch);
    return executor.start(std::move(ref));
  }
  std::uint64_t start_paper() { return start_paper(executor.estop_epoch()); }
  const LoopEvent* find(K kind, std::uint64_t id) const {
    for (const auto& e : events)
      if (e.kind == kind && e.id == id) return &e;
    return nullptr;
  }
  // Steps until an event of `kind` for `id` (at most `max` cycles).
  const LoopEvent* until(K kind, std::uint64_t id, int max = 20000) {
    for (int k = 0; k < max && !find(kind, id); ++k) step();
    return find(kind, id);
  }
  model::JointVector q() const { return plant.output().q; }

  sim::Plant plant;
  sim::SimActuatorSet sim;
  safety::FaultInjector faults;
  Gate gate;
  Executor executor;
  std::int64_t cycle = 0;
  std::vector<LoopEvent> events;
  std::vector<safety::FaultEvent> faults_logged;
  double max_torque = 0.0;
};

TEST(Executor, IdleSendsZeroTorqueWithDrivesDisabledAndReportsThePose) {
  LoopRig r;
  EXPECT_EQ(r.executor.snapshot().cycle, -1);  // nothing ran yet: no pose to prepare on
  EXPECT_THROW(r.start_paper(), std::runtime_error);
  r.steps(500);
  const LoopSnapshot s = r.executor.snapshot();
  EXPECT_EQ(s.cycle, 499);
  EXPECT_EQ(s.mode, LoopMode::kIdle);
  EXPECT_EQ(s.safety, SafetyState::kDisabled);
  ASSERT_TRUE(s.pose_valid);
  // Forward kinematics from the encoders (independent of the reference): the home pose.
  EXPECT_NEAR((s.pose() - robot().model.home).norm(), 0.0, 1e-6);
  EXPECT_EQ(r.gate.last.request, DriveRequest::kDisable);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(r.gate.last.torque[i], 0.0);
  EXPECT_EQ(r.executor.record().status, CycleStatus::kOk);
  EXPECT_TRUE(r.events.empty());
  EXPECT_TRUE(r.faults_logged.empty());
}

TEST(Executor, AStartEnablesAtZeroTorqueRunsToTheEndAndReturnsToIdle) {
  LoopRig r;
  r.steps(1000);  // a long idle first: the loop never stopped writing
  const model::JointVector q0 = r.q();
  const std::uint64_t id = r.start_paper();
  ASSERT_GT(id, 0u);
  ASSERT_NE(r.until(K::kStarted, id, 2), nullptr);
  // Enabling: zero torque until every drive is enabled, and nothing moves.
  int enabling = 0;
  while (r.executor.record().phase == CyclePhase::kEnabling) {
    EXPECT_EQ(r.gate.last.request, DriveRequest::kEnable);
    for (int i = 0; i < 4; ++i) EXPECT_EQ(r.gate.last.torque[i], 0.0);
    r.step();
    ASSERT_LT(++enabling, 2000);
  }
  EXPECT_LT((r.q() - q0).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_EQ(r.executor.snapshot().mode, LoopMode::kProgram);
  const LoopEvent* done = r.until(K::kFinished, id);
  ASSERT_NE(done, nullptr);
  EXPECT_EQ(r.find(K::kStopped, id), nullptr);
  r.step();
  EXPECT_EQ(r.executor.snapshot().mode, LoopMode::kIdle);
  EXPECT_EQ(r.gate.last.request, DriveRequest::kDisable);  // loop.idle: disabled
  // The program ran on the loop's count: finished after its duration plus settle time.
  EXPECT_GE(done->t, paper().duration());
  EXPECT_TRUE(r.faults_logged.size() <= 2u);  // armed (+ nothing else)
  for (const auto& f : r.faults_logged) EXPECT_NE(f.kind, safety::EventKind::kFault);
}

TEST(Executor, IdleHoldKeepsTheFinalPoseEnabledAndTheNextStartNeedsNoEnabling) {
  LoopRig r(IdleMode::kHold);
  r.steps(10);
  const std::uint64_t a = r.start_paper();
  ASSERT_NE(r.until(K::kFinished, a), nullptr);
  r.steps(500);
  const LoopSnapshot s = r.executor.snapshot();
  EXPECT_EQ(s.mode, LoopMode::kHold);
  EXPECT_EQ(s.safety, SafetyState::kOperational);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(r.sim.state(i), DriveState::kEnabled);
  EXPECT_LT(r.plant.output().q_dot.cwiseAbs().maxCoeff(), 1e-3);  // held at rest
  const std::uint64_t b = r.start_paper();
  ASSERT_NE(r.until(K::kStarted, b, 2), nullptr);
  EXPECT_EQ(r.executor.record().phase, CyclePhase::kRunning);
  // A stop while holding lets go: idle, disabled, nothing latched.
  ASSERT_NE(r.until(K::kFinished, b), nullptr);
  ASSERT_TRUE(r.executor.submit(LoopCommand::Kind::kStop));
  r.steps(2);
  EXPECT_EQ(r.executor.snapshot().mode, LoopMode::kIdle);
  EXPECT_EQ(r.executor.snapshot().latched, 0u);
}

TEST(Executor, AnEstopCountedBeforeTheFirstCycleLatchesAndRefusesStarts) {
  LoopRig r;
  std::atomic<std::uint64_t> estops{1};  // came while the drives were booting
  r.executor.watch_estops(&estops);
  r.steps(3);
  EXPECT_EQ(r.executor.snapshot().mode, LoopMode::kSafeStop);
  EXPECT_EQ(r.executor.snapshot().safety, SafetyState::kSto);
  ASSERT_NE(r.find(K::kStopped, 0), nullptr);
  const std::uint64_t id = r.start_paper();
  const LoopEvent* refused = r.until(K::kRefused, id, 2);
  ASSERT_NE(refused, nullptr);
  EXPECT_EQ(refused->reason, RefuseReason::kLatched);
  EXPECT_EQ(r.gate.last.request, DriveRequest::kDisable);
}

TEST(Executor, AnEstopWhileIdleNeedsAResetThenAStartRuns) {
  LoopRig r;
  r.steps(5);
  r.executor.request_estop(safety::StopSource::kLcm);
  r.step();
  EXPECT_EQ(r.executor.snapshot().safety, SafetyState::kSto);
  const std::uint64_t refused = r.start_paper();
  ASSERT_NE(r.until(K::kRefused, refused, 2), nullptr);
  ASSERT_TRUE(r.executor.submit(LoopCommand::Kind::kReset));
  ASSERT_NE(r.until(K::kReset, 0, 10), nullptr);
  EXPECT_EQ(r.executor.snapshot().mode, LoopMode::kIdle);
  r.steps(100);  // a reset never starts motion
  EXPECT_EQ(r.gate.last.request, DriveRequest::kDisable);
  const std::uint64_t id = r.start_paper();
  ASSERT_NE(r.until(K::kFinished, id), nullptr);
}

TEST(Executor, AnEstopDuringPreparationMeansThatProgramNeverStarts) {
  LoopRig r;
  r.steps(5);
  const std::uint64_t epoch = r.executor.estop_epoch();  // the start is asked for
  auto ref = r.executor.prepare_program(paper(), robot().trajectory.rebase, epoch);
  std::atomic<std::uint64_t> channel{0};
  r.executor.watch_estops(&channel);
  channel = 1;  // the e-stop arrives (e.g. over LCM) while it is prepared ...
  const std::uint64_t id = r.executor.start(std::move(ref));  // ... and then it is handed over
  const model::JointVector q0 = r.q();
  const LoopEvent* e = r.until(K::kRefused, id, 2);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->reason, RefuseReason::kEstop);
  r.steps(200);
  EXPECT_EQ(r.find(K::kStarted, id), nullptr);
  EXPECT_EQ(r.executor.snapshot().safety, SafetyState::kSto);  // and the e-stop is latched
  EXPECT_EQ(r.gate.last.request, DriveRequest::kDisable);
  EXPECT_EQ(r.max_torque, 0.0);
  EXPECT_LT((r.q() - q0).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Executor, AnEstopWhileRunningIsSs1ThenStoThenResetAndRunAgain) {
  LoopRig r;
  r.steps(2);
  const std::uint64_t id = r.start_paper();
  ASSERT_NE(r.until(K::kStarted, id, 2), nullptr);
  for (int k = 0; k < 20000 && !(r.executor.record().phase == CyclePhase::kRunning &&
                                 r.executor.record().t > 1.5);
       ++k)
    r.step();
  r.executor.request_estop(safety::StopSource::kSignal);
  r.step();
  const LoopEvent* stopped = r.find(K::kStopped, id);
  ASSERT_NE(stopped, nullptr);
  EXPECT_EQ(stopped->status, CycleStatus::kSafetyStop);
  EXPECT_EQ(r.executor.snapshot().safety, SafetyState::kSs1);
  EXPECT_EQ(r.executor.snapshot().mode, LoopMode::kSafeStop);
  ASSERT_NE(r.until(K::kTorqueOff, 0, 5000), nullptr);
  EXPECT_EQ(r.executor.snapshot().safety, SafetyState::kSto);
  EXPECT_EQ(r.find(K::kFinished, id), nullptr);
  r.executor.submit(LoopCommand::Kind::kReset);
  ASSERT_NE(r.until(K::kReset, 0, 10), nullptr);
  const std::uint64_t again = r.start_paper();
  ASSERT_NE(r.until(K::kFinished, again), nullptr);
}

TEST(Executor, StopIsSs1ForAProgramAndANormalEndForAStream) {
  LoopRig r;
  r.steps(2);
  const std::uint64_t id = r.start_paper();
  r.steps(1500);
  r.executor.submit(LoopCommand::Kind::kStop);
  ASSERT_NE(r.until(K::kStopped, id, 3), nullptr);
  ASSERT_NE(r.until(K::kTorqueOff, 0, 5000), nullptr);
  r.executor.submit(LoopCommand::Kind::kReset);
  ASSERT_NE(r.until(K::kReset, 0, 10), nullptr);

  auto stream = r.executor.prepare_stream(
      robot().trajectory.streaming, robot().trajectory.limits.workspace, r.executor.estop_epoch());
  const std::uint64_t sid = r.executor.start(std::move(stream));
  ASSERT_NE(r.until(K::kStarted, sid, 2), nullptr);
  EXPECT_EQ(r.executor.mode(), LoopMode::kStream);
  model::Pose target = robot().model.home;
  target.x() += 0.01;
  for (int k = 0; k < 400; ++k) {
    r.executor.stream_setpoint(target);  // as the hooks hand them on, every cycle
    r.step();
  }
  EXPECT_NEAR(r.executor.snapshot().X[0], target.x(), 1e-3);
  r.executor.submit(LoopCommand::Kind::kStop);
  ASSERT_NE(r.until(K::kFinished, sid, 3000), nullptr);
  EXPECT_EQ(r.find(K::kStopped, sid), nullptr);
  EXPECT_EQ(r.executor.snapshot().latched, 0u);
}

// A stream ended in the cycle it starts in (both commands queued before the loop takes
// them): it starts and ends normally, no stale stream.
TEST(Executor, AStreamEndedInTheCycleItStartsFinishesNormally) {
  LoopRig r;
  r.steps(2);
  const std::uint64_t sid = r.executor.start(r.executor.prepare_stream(
      robot().trajectory.streaming, robot().trajectory.limits.workspace, r.executor.estop_epoch()));
  ASSERT_TRUE(r.executor.submit(LoopCommand::Kind::kEndStream));
  ASSERT_NE(r.until(K::kStarted, sid, 2), nullptr);
  ASSERT_NE(r.until(K::kFinished, sid, 3000), nullptr);
  EXPECT_EQ(r.find(K::kStopped, sid), nullptr);
  EXPECT_EQ(r.executor.snapshot().latched, 0u);
}

TEST(Executor, RefusesAStartWhileBusyOrWhenTheRobotMovedSincePreparation) {
  LoopRig r;
  r.steps(2);
  const std::uint64_t a = r.start_paper();
  r.steps(10);
  const std::uint64_t busy = r.start_paper();
  const LoopEvent* e = r.until(K::kRefused, busy, 2);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->reason, RefuseReason::kBusy);
  ASSERT_NE(r.until(K::kFinished, a), nullptr);
  r.steps(300);
  // Prepared at one pose, taken after the plate was moved 5 mm (e.g. by hand, disabled).
  auto ref =
      r.executor.prepare_program(paper(), robot().trajectory.rebase, r.executor.estop_epoch());
  model::Pose moved = r.executor.snapshot().pose();
  moved.x() += 0.005;
  r.plant.reset(moved);
  r.steps(2);
  const std::uint64_t late = r.executor.start(std::move(ref));
  e = r.until(K::kRefused, late, 2);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->reason, RefuseReason::kMoved);
  EXPECT_EQ(r.gate.last.request, DriveRequest::kDisable);
}

TEST(Executor, DrivesThatNeverEnableEndTheStartWithEnableTimeoutNothingLatched) {
  LoopRig r;
  r.gate.never_enable = true;
  r.steps(2);
  const std::uint64_t id = r.start_paper();
  const LoopEvent* e = r.until(K::kStopped, id, 3000);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->status, CycleStatus::kEnableTimeout);
  // 2 s (CycleConfig::enable_timeout) at 1 kHz after the take-over.
  EXPECT_NEAR(static_cast<double>(e->cycle - r.find(K::kStarted, id)->cycle), 2000.0, 2.0);
  r.step();
  EXPECT_EQ(r.executor.snapshot().mode, LoopMode::kIdle);
  EXPECT_EQ(r.executor.snapshot().latched, 0u);
  EXPECT_EQ(r.gate.last.request, DriveRequest::kDisable);
}

TEST(Executor, ABusErrorOrAnInvalidEstimateStopsTheProgram) {
  for (const bool bus : {true, false}) {
    LoopRig r;
    r.steps(2);
    const std::uint64_t id = r.start_paper();
    r.steps(1500);
    if (bus)
      r.gate.bus_error = true;
    else
      r.faults.corrupt_position(1, true);
    r.step();
    const LoopEvent* e = r.find(K::kStopped, id);
    ASSERT_NE(e, nullptr) << bus;
    EXPECT_EQ(e->status, bus ? CycleStatus::kIoError : CycleStatus::kEstimateFailed);
    EXPECT_EQ(r.executor.record().status,
              bus ? CycleStatus::kIoError : CycleStatus::kEstimateFailed);
    EXPECT_EQ(r.executor.snapshot().mode, LoopMode::kSafeStop);
  }
}

TEST(Executor, ADriveFaultIsStoAndASignedResetRunsTheFaultResetWithoutReenabling) {
  LoopRig r;
  r.steps(2);
  const std::uint64_t id = r.start_paper();
  r.steps(1500);
  r.sim.inject_fault(2, 0x2310);
  r.step();
  ASSERT_NE(r.find(K::kStopped, id), nullptr);
  EXPECT_EQ(r.executor.snapshot().safety, SafetyState::kSto);
  r.steps(200);
  EXPECT_EQ(r.sim.state(2), DriveState::kFault);  // nothing clears by itself
  r.executor.submit(LoopCommand::Kind::kReset);
  bool fault_reset_sent = false;
  for (int k = 0; k < 100 && !r.find(K::kReset, 0); ++k) {
    r.step();
    fault_reset_sent = fault_reset_sent || r.gate.last.request == DriveRequest::kFaultReset;
  }
  EXPECT_TRUE(fault_reset_sent);
  ASSERT_NE(r.find(K::kReset, 0), nullptr);
  r.steps(500);
  for (int i = 0; i < 4; ++i) EXPECT_NE(r.sim.state(i), DriveState::kEnabled);
  EXPECT_NE(r.sim.state(2), DriveState::kFault);
  const std::uint64_t again = r.start_paper();
  ASSERT_NE(r.until(K::kFinished, again), nullptr);
}

TEST(Executor, ShutdownStopsAMovingRobotFirstThenEnds) {
  LoopRig r;
  r.steps(2);
  r.start_paper();
  r.steps(1500);
  r.executor.submit(LoopCommand::Kind::kShutdown);
  int k = 0;
  while (r.step() == CycleResult::kContinue) ASSERT_LT(++k, 5000);
  EXPECT_GT(k, 5);  // SS1 took its cycles
  EXPECT_EQ(r.executor.snapshot().safety, SafetyState::kSto);
  ASSERT_NE(r.find(K::kLoopEnded, 0), nullptr);
  // Idle, a shutdown ends at once.
  LoopRig idle;
  idle.steps(3);
  idle.executor.submit(LoopCommand::Kind::kShutdown);
  EXPECT_EQ(idle.step(), CycleResult::kStop);
}

TEST(Executor, CyclesAllocateNothingIdleRunningOrStopping) {
  LoopRig r;
  r.steps(2);
  auto ref =
      r.executor.prepare_program(paper(), robot().trajectory.rebase, r.executor.estop_epoch());
  r.events.reserve(1000);
  r.faults_logged.reserve(1000);
  const std::uint64_t id = r.executor.start(std::move(ref));
  (void)id;
  test::start_counting();
  for (int k = 0; k < 3000; ++k) {
    r.executor.step(CycleInfo{});
    r.plant.advance(robot().period());
  }
  r.executor.request_estop(safety::StopSource::kLcm);
  for (int k = 0; k < 1000; ++k) {
    r.executor.step(CycleInfo{});
    r.plant.advance(robot().period());
  }
  EXPECT_EQ(test::stop_counting(), 0L);
  EXPECT_EQ(r.executor.snapshot().safety, SafetyState::kSto);
}

// The loop on its own thread (control/loop/loop_thread.hpp) with the supervisor on this one:
// what crosses threads is only the queues and the snapshot (run under ThreadSanitizer by
// scripts/test.sh). Asserts the order of events, never timing.
TEST(Executor, OnItsOwnThreadTheSupervisorStartsAStreamStopsItAndShutsTheLoopDown) {
  struct PlantHooks final : LoopHooks {
    explicit PlantHooks(sim::Plant& p) : plant(p) {}
    void after_cycle(const Executor&, const CycleRecord&, const CycleInfo&) noexcept override {
      plant.advance(robot().period());
    }
    sim::Plant& plant;
  };
  sim::Plant plant(robot().model, robot().plant);
  plant.reset(robot().model.home);
  sim::SimActuatorSet io(plant);
  Executor ex(robot().model, robot().control, LoopRig::config(IdleMode::kDisabled), io);
  PlantHooks hooks(plant);
  ex.set_hooks(&hooks);
  ExecutiveConfig exec = robot().loop;
  exec.realtime = false;  // no SCHED_FIFO needed for this
  MonotonicClock clock;
  LoopThread thread(exec, clock);
  thread.launch();
  thread.go(ex);
  std::vector<LoopEvent> events;
  auto wait_for_either = [&](K kind, K other) {
    for (int k = 0; k < 30000; ++k) {  // up to 30 s on a loaded machine
      LoopEvent e;
      while (ex.poll_event(e)) events.push_back(e);
      for (const auto& e2 : events)
        if (e2.kind == kind || e2.kind == other) return true;
      ex.collect();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return false;
  };
  auto wait_for = [&](K kind) { return wait_for_either(kind, kind); };
  while (ex.snapshot().cycle < 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const std::uint64_t id = ex.start(ex.prepare_stream(
      robot().trajectory.streaming, robot().trajectory.limits.workspace, ex.estop_epoch()));
  // The end of the stream right behind its start in the same queue (taken in that order): a
  // supervisor slowed past the stream watchdog (0.1 s without a setpoint) between the two
  // would have it stopped as stale.
  ASSERT_TRUE(ex.submit(LoopCommand::Kind::kEndStream));
  ASSERT_TRUE(wait_for(K::kStarted));
  // It ends normally; on a machine so loaded that this thread, not real-time here, misses its
  // deadlines, the safety filter stops it on those misses first (what this test asserts is
  // the order through the queues, whatever the timing: the same end on simulated time,
  // AStreamEndedInTheCycleItStartsFinishesNormally).
  ASSERT_TRUE(wait_for_either(K::kFinished, K::kStopped));
  bool finished = false;
  for (const auto& e : events) {
    if (e.kind == K::kFinished) finished = true;
    if (e.kind == K::kStopped) {
      EXPECT_NE(e.latched & safety::bit(safety::Fault::kDeadlineMisses), 0u)
          << "stopped by " << safety::describe_faults(e.latched);
    }
  }
  ASSERT_TRUE(ex.submit(LoopCommand::Kind::kShutdown));
  ASSERT_TRUE(wait_for(K::kLoopEnded));
  const RunReport report = thread.join();
  EXPECT_GT(report.cycles, 0);
  EXPECT_EQ(events.front().kind, K::kStarted);
  EXPECT_EQ(events.front().id, id);
  if (finished) {
    EXPECT_EQ(ex.snapshot().mode, LoopMode::kIdle);
  }
}

}  // namespace
}  // namespace dualv::control
