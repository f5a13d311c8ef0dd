// The safety filter on simulated time: every limit is detected in the cycle its data shows
// the violation, every cycle-counted watchdog at exactly T cycles (and not at T - 1), the
// configured reaction is applied in the detection cycle, no output torque is above its
// limit, and every detection is in the fault log.
#include "safety/safety_filter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <thread>

#include "safety_bench.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::safety::test {
namespace {

using drivers::DriveRequest;
using drivers::DriveState;

// Arms and runs a few clean cycles.
void settle(Bench& b, int cycles = 5) {
  ASSERT_EQ(b.arm(), ArmStatus::kOk);
  for (int k = 0; k < cycles; ++k) ASSERT_EQ(b.step(), SafetyState::kOperational);
  ASSERT_EQ(b.filter->report().latched, 0u);
}

// The fault was logged in the current cycle with its table reaction and `latency`.
void expect_logged(Bench& b, Fault f, int latency = 0) {
  const FaultEvent* e = b.find(f);
  ASSERT_NE(e, nullptr) << to_string(f) << " not in the fault log";
  EXPECT_EQ(e->cycle, b.cycle) << to_string(f);
  EXPECT_EQ(e->reaction, reaction_of(f)) << to_string(f);
  EXPECT_EQ(e->latency_cycles, latency) << to_string(f);
}

void expect_sto(const Bench& b) {
  EXPECT_EQ(b.filter->state(), SafetyState::kSto);
  EXPECT_EQ(b.out.request, DriveRequest::kDisable);
  EXPECT_EQ(b.max_abs_out(), 0.0);
}

TEST(SafetyFilter, NominalCommandPassesUnchanged) {
  Bench b;
  settle(b);
  b.in.command.torque = {1.0, -2.0, 3.0, -4.0};
  b.in.command.request = DriveRequest::kEnable;
  // Ramp within the rate limit (30 N m per cycle at 1 kHz by default).
  EXPECT_EQ(b.step(), SafetyState::kOperational);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(b.out.torque[i], b.in.command.torque[i]);
  EXPECT_EQ(b.out.request, DriveRequest::kEnable);
  EXPECT_FALSE(b.filter->report().torque_limited);
  for (int k = 0; k < 1000; ++k) ASSERT_EQ(b.step(), SafetyState::kOperational);
  ASSERT_NE(b.find(EventKind::kArmed), nullptr);
  EXPECT_EQ(b.events().size(), 1u);  // only "armed"
}

TEST(SafetyFilter, DisabledUntilArmed) {
  Bench b;
  b.in.command.torque = {5, 5, 5, 5};
  b.in.command.request = DriveRequest::kEnable;
  EXPECT_EQ(b.step(), SafetyState::kDisabled);
  EXPECT_EQ(b.out.request, DriveRequest::kDisable);
  EXPECT_EQ(b.max_abs_out(), 0.0);
}

TEST(SafetyFilter, TorqueTenTimesTheLimitIsClampedAndStopsWithSs1) {
  Bench b;
  settle(b);
  b.in.command.torque = {600.0, -600.0, 600.0, -600.0};
  EXPECT_EQ(b.step(), SafetyState::kSs1);
  expect_logged(b, Fault::kTorqueLimit);
  EXPECT_LE(b.max_abs_out(), b.cfg.torque.max);
  EXPECT_LE(b.max_abs_out(), b.filter->limits().torque_step + 1e-12);
  EXPECT_EQ(b.out.request, DriveRequest::kHold);  // SS1 brakes under power
  const FaultEvent* e = b.find(Fault::kTorqueLimit);
  EXPECT_EQ(e->value, 600.0);
  EXPECT_EQ(e->limit, b.cfg.torque.max);
}

TEST(SafetyFilter, TorqueJustAtTheLimitPassesJustAboveStops) {
  SafetyConfig c;
  c.torque.max_rate = 1e6;  // one cycle may reach the limit
  Bench b(c);
  settle(b);
  b.in.command.torque = {c.torque.max, -c.torque.max, 0, 0};
  EXPECT_EQ(b.step(), SafetyState::kOperational);
  EXPECT_EQ(b.max_abs_out(), c.torque.max);
  b.in.command.torque = {std::nextafter(c.torque.max, 1e9), 0, 0, 0};
  EXPECT_EQ(b.step(), SafetyState::kSs1);
  expect_logged(b, Fault::kTorqueLimit);
  EXPECT_LE(b.max_abs_out(), c.torque.max);
}

TEST(SafetyFilter, TorqueRateAtTheLimitPassesAboveStops) {
  Bench b;
  settle(b);
  const double step = b.filter->limits().torque_step;
  b.in.command.torque = {step, 0, 0, 0};
  EXPECT_EQ(b.step(), SafetyState::kOperational);
  b.in.command.torque = {2 * step + 0.01, 0, 0, 0};
  EXPECT_EQ(b.step(), SafetyState::kSs1);
  expect_logged(b, Fault::kTorqueRate);
  EXPECT_LE(std::abs(b.out.torque[0] - step), step + 1e-12);
}

TEST(SafetyFilter, NonFiniteCommandStopsWithFiniteOutput) {
  for (double bad :
       {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
        -std::numeric_limits<double>::infinity()}) {
    Bench b;
    settle(b);
    b.in.command.torque = {0, 0, bad, 0};
    EXPECT_EQ(b.step(), SafetyState::kSs1);
    expect_logged(b, Fault::kNonFiniteCommand);
    for (int i = 0; i < 4; ++i) EXPECT_TRUE(std::isfinite(b.out.torque[i]));
  }
}

TEST(SafetyFilter, JointVelocityBelowPassesAboveStopsInTheSameCycle) {
  SafetyConfig c;
  c.max_plate_velocity = 10.0;  // look at the joint monitor alone
  c.max_plate_angular_velocity = 100.0;
  for (const double factor : {0.99, 1.01}) {
    Bench b(c);
    settle(b);
    const double dq = factor * c.max_joint_velocity * b.period;
    for (int k = 0; k < 3; ++k) {
      b.fb.drive[2].position += dq;
      const SafetyState s = b.step();
      if (factor < 1.0) {
        EXPECT_EQ(s, SafetyState::kOperational) << k;
      } else {
        EXPECT_EQ(s, SafetyState::kSs1);
        expect_logged(b, Fault::kJointVelocity);
        EXPECT_EQ(b.find(Fault::kJointVelocity)->drive, 2);
        break;
      }
    }
  }
}

TEST(SafetyFilter, PlateVelocityBelowPassesAboveStops) {
  SafetyConfig c;
  c.max_joint_velocity = 100.0;
  for (const double factor : {0.98, 1.02}) {
    Bench b(c);
    settle(b);
    model::Pose X = dual_v().home;
    const double dx = factor * c.max_plate_velocity * b.period;
    for (int k = 0; k < 5; ++k) {
      X.x() += dx;
      b.set_pose(X);
      const SafetyState s = b.step();
      if (factor < 1.0) {
        EXPECT_EQ(s, SafetyState::kOperational) << k;
      } else {
        EXPECT_EQ(s, SafetyState::kSs1);
        expect_logged(b, Fault::kPlateVelocity);
        break;
      }
    }
  }
}

TEST(SafetyFilter, WorkspaceEdgesAreCheckedExactly) {
  SafetyConfig c;
  c.max_joint_velocity = 1e3 / 1.0;
  c.max_joint_velocity = 100.0;
  c.max_plate_velocity = 10.0;
  c.max_plate_angular_velocity = 100.0;
  c.max_encoder_jump = 3.0;
  struct Case {
    int axis;
    double inside, outside;
  };
  const Case cases[] = {{0, c.workspace.x.hi, c.workspace.x.hi + 1e-6},
                        {0, c.workspace.x.lo, c.workspace.x.lo - 1e-6},
                        {1, c.workspace.y.hi, c.workspace.y.hi + 1e-6},
                        {2, c.workspace.theta.lo, c.workspace.theta.lo - 1e-6}};
  for (const Case& cs : cases) {
    Bench b(c);
    model::Pose X = dual_v().home;
    X[cs.axis] = cs.inside;
    b.set_pose(X);
    settle(b, 2);
    X[cs.axis] = cs.outside;
    b.set_pose(X);
    EXPECT_EQ(b.step(), SafetyState::kSs1) << cs.axis;
    expect_logged(b, Fault::kWorkspace);
  }
}

TEST(SafetyFilter, SingularityDistanceBelowItsMinimumStops) {
  model::Data d(dual_v());
  ASSERT_EQ(model::update_kinematics(dual_v(), d, dual_v().home, model::Twist::Zero()),
            model::Status::kOk);
  const model::SingularityMeasures sm = model::singularity_measures(dual_v(), d);
  for (const bool parallel : {true, false}) {
    SafetyConfig c;
    (parallel ? c.min_parallel_singularity : c.min_serial_singularity) =
        0.999 * (parallel ? sm.parallel : sm.min_serial);
    Bench ok(c);
    settle(ok, 3);
    (parallel ? c.min_parallel_singularity : c.min_serial_singularity) =
        1.001 * (parallel ? sm.parallel : sm.min_serial);
    Bench b(c);
    ASSERT_EQ(b.arm(), ArmStatus::kOk);
    EXPECT_EQ(b.step(), SafetyState::kSs1);
    expect_logged(b, Fault::kSingularity);
  }
}

TEST(SafetyFilter, TrackingErrorPositionAndAngle) {
  Bench b;
  settle(b);
  b.in.tracking = true;
  b.in.X_d = b.in.X + model::Pose(0.0, 0.999 * b.cfg.max_tracking_error, 0.0);
  EXPECT_EQ(b.step(), SafetyState::kOperational);
  b.in.X_d = b.in.X + model::Pose(0.0, 0.0, 0.999 * b.cfg.max_tracking_error_angle);
  EXPECT_EQ(b.step(), SafetyState::kOperational);
  b.in.X_d = b.in.X + model::Pose(1.001 * b.cfg.max_tracking_error, 0.0, 0.0);
  EXPECT_EQ(b.step(), SafetyState::kSs1);
  expect_logged(b, Fault::kTrackingError);
  EXPECT_NEAR(b.find(Fault::kTrackingError)->value, 1.001 * b.cfg.max_tracking_error, 1e-12);
}

TEST(SafetyFilter, EncoderJumpIsStoInTheSameCycle) {
  Bench b;
  settle(b);
  b.fb.drive[1].position += 0.99 * b.cfg.max_encoder_jump * 0.1;  // a fast but real motion
  b.cfg.max_joint_velocity = 1e9;
  EXPECT_NE(b.step(), SafetyState::kSto);
  Bench j;
  settle(j);
  j.fb.drive[1].position += 1.01 * j.cfg.max_encoder_jump;
  EXPECT_EQ(j.step(), SafetyState::kSto);
  expect_sto(j);
  expect_logged(j, Fault::kEncoderJump);
}

TEST(SafetyFilter, StaleFeedbackAtExactlyTheConfiguredCycles) {
  Bench b;
  settle(b);
  const int k = b.cfg.watchdogs.stale_feedback_cycles;
  b.fb.drive[3].fresh = false;
  for (int c = 1; c < k; ++c) EXPECT_EQ(b.step(), SafetyState::kOperational) << "cycle " << c;
  EXPECT_EQ(b.step(), SafetyState::kSto);  // the k-th stale cycle
  expect_sto(b);
  expect_logged(b, Fault::kStaleFeedback, k - 1);
  EXPECT_EQ(b.find(Fault::kStaleFeedback)->drive, 3);
}

TEST(SafetyFilter, DriveLostStopsAllDrivesAtOnce) {
  Bench b;
  settle(b);
  b.in.command.torque = {5, 5, 5, 5};
  b.step();
  b.fb.drive[0].state = DriveState::kOffline;
  EXPECT_EQ(b.step(), SafetyState::kSto);
  expect_sto(b);  // one request for all drives: every drive disabled, 0 N m on each
  expect_logged(b, Fault::kDriveLost);
  // The event carries the torque sent in the detection cycle (0: torque off at once).
  for (int i = 0; i < 4; ++i) EXPECT_EQ(b.find(Fault::kDriveLost)->torque[i], 0.0);
}

TEST(SafetyFilter, DriveFaultAndEstopInputAreSto) {
  {
    Bench b;
    settle(b);
    b.fb.drive[2].state = DriveState::kFault;
    b.fb.drive[2].last_emcy = 0x2310;
    EXPECT_EQ(b.step(), SafetyState::kSto);
    expect_sto(b);
    expect_logged(b, Fault::kDriveFault);
    EXPECT_EQ(b.find(Fault::kDriveFault)->value, 0x2310);
  }
  {
    Bench b;
    settle(b);
    b.fb.drive[0].stop_input = true;
    EXPECT_EQ(b.step(), SafetyState::kSto);
    expect_sto(b);
    expect_logged(b, Fault::kEstopInput);
  }
  {
    Bench b;
    settle(b);
    b.in.io_status = drivers::IoStatus::kBusError;
    EXPECT_EQ(b.step(), SafetyState::kSto);
    expect_logged(b, Fault::kBusError);
  }
  {
    Bench b;
    settle(b);
    b.in.pose_valid = false;
    EXPECT_EQ(b.step(), SafetyState::kSto);
    expect_logged(b, Fault::kInvalidState);
  }
}

TEST(SafetyFilter, ADriveLeavingOperationEnabledOnItsOwnIsSto) {
  Bench b;
  settle(b);  // every drive enabled
  b.fb.drive[3].state = DriveState::kQuickStop;
  EXPECT_EQ(b.step(), SafetyState::kSto);
  expect_sto(b);
  expect_logged(b, Fault::kDriveFault);
  // While enabling (not every drive enabled yet since arm), disabled drives are expected.
  Bench e;
  for (int i = 0; i < 4; ++i) e.fb.drive[i].state = DriveState::kDisabled;
  ASSERT_EQ(e.arm(), ArmStatus::kOk);
  e.in.command.request = DriveRequest::kEnable;
  for (int k = 0; k < 10; ++k) EXPECT_EQ(e.step(), SafetyState::kOperational);
}

TEST(SafetyFilter, DeadlineMissesWarnThenStopAtN) {
  Bench b;
  settle(b);
  const int n = b.cfg.watchdogs.max_consecutive_deadline_misses;
  b.in.deadline_missed = true;
  for (int c = 1; c < n; ++c) {
    b.in.consecutive_deadline_misses = c;
    EXPECT_EQ(b.step(), SafetyState::kOperational) << c;
  }
  const FaultEvent* warn = b.find(Fault::kDeadlineMiss);
  ASSERT_NE(warn, nullptr);
  EXPECT_EQ(warn->reaction, Reaction::kWarn);
  b.in.consecutive_deadline_misses = n;
  EXPECT_EQ(b.step(), SafetyState::kSto);
  expect_logged(b, Fault::kDeadlineMisses, n - 1);
}

TEST(SafetyFilter, CommandStreamTimeoutExactly) {
  SafetyConfig c;
  c.watchdogs.command_stream_timeout = 0.05;  // 50 cycles at 1 kHz
  Bench b(c);
  settle(b);
  b.in.streaming = true;
  b.in.stream_fresh = true;
  b.step();
  b.in.stream_fresh = false;
  const int T = b.filter->limits().stream_timeout;
  ASSERT_EQ(T, 50);
  for (int k = 1; k < T; ++k) ASSERT_EQ(b.step(), SafetyState::kOperational) << k;
  EXPECT_EQ(b.step(), SafetyState::kSs1);
  expect_logged(b, Fault::kCommandStreamStale, T - 1);
  // Not streaming: no timeout however long.
  Bench q(c);
  settle(q);
  for (int k = 0; k < 200; ++k) ASSERT_EQ(q.step(), SafetyState::kOperational);
}

TEST(SafetyFilter, EstopRequestFromAnotherThreadLatchesNextCycle) {
  Bench b;
  settle(b);
  std::thread t([&] { b.filter->request_stop(StopSource::kLcm); });
  t.join();
  EXPECT_EQ(b.step(), SafetyState::kSs1);
  expect_logged(b, Fault::kEstopLcm);
}

// Decoupled joints with inertia J: q_dd = tau / J. The SS1 brake must bring them to
// standstill within ss1.max_time and then take the torque off (kDisable).
TEST(SafetyFilter, Ss1BrakesToStandstillThenSto) {
  SafetyConfig c;
  c.max_plate_velocity = 10.0;  // the joints below move independently
  c.max_plate_angular_velocity = 100.0;
  Bench m(c);
  const double J = 0.05;  // [kg m^2] about the reflected inertia at a crank
  std::array<double, 4> q{}, qd{2.0, -3.0, 1.5, -0.5};
  for (int i = 0; i < 4; ++i) q[i] = m.fb.drive[i].position;
  ASSERT_EQ(m.arm(), ArmStatus::kOk);
  auto advance = [&] {
    for (int i = 0; i < 4; ++i) {
      const double tau = m.out.request == DriveRequest::kDisable ? 0.0 : m.out.torque[i];
      qd[i] += tau / J * m.period;
      q[i] += qd[i] * m.period;
      m.fb.drive[i].position = q[i];
    }
  };
  for (int k = 0; k < 3; ++k) {  // moving: the filter's velocity estimate settles
    advance();
    ASSERT_EQ(m.step(), SafetyState::kOperational);
  }
  m.filter->request_stop(StopSource::kCli);
  int ss1_cycles = 0;
  while (m.step() == SafetyState::kSs1) {
    ++ss1_cycles;
    ASSERT_LE(m.max_abs_out(), c.ss1.max_torque);
    advance();
    ASSERT_LT(ss1_cycles, 10000);
  }
  ASSERT_NE(m.find(Fault::kEstopCli), nullptr);
  EXPECT_EQ(m.filter->state(), SafetyState::kSto);
  EXPECT_GT(ss1_cycles, 10);  // it did brake under power first
  EXPECT_LE(ss1_cycles, m.filter->limits().ss1_max);
  EXPECT_EQ(m.out.request, DriveRequest::kDisable);
  for (int i = 0; i < 4; ++i) EXPECT_LT(std::abs(qd[i]), c.ss1.standstill_velocity);
  EXPECT_NE(m.find(EventKind::kStopReached), nullptr);
  EXPECT_EQ(m.find(Fault::kStopTimeout), nullptr);
}

TEST(SafetyFilter, Ss1TimeoutGoesStoAtExactlyMaxTime) {
  SafetyConfig c;
  c.ss1.damping = 0.0;  // no braking at all: standstill never comes
  c.max_joint_velocity = 100.0;
  c.max_plate_velocity = 10.0;
  c.max_plate_angular_velocity = 100.0;
  Bench b(c);
  ASSERT_EQ(b.arm(), ArmStatus::kOk);
  const double dq = 1.0 * b.period;  // 1 rad/s on drive 0, forever
  b.fb.drive[0].position += dq;
  b.step();
  b.filter->request_stop(StopSource::kSignal);
  const int T = b.filter->limits().ss1_max;
  for (int k = 1; k < T; ++k) {
    b.fb.drive[0].position += dq;
    ASSERT_EQ(b.step(), SafetyState::kSs1) << k;
  }
  b.fb.drive[0].position += dq;
  EXPECT_EQ(b.step(), SafetyState::kSto);
  expect_sto(b);
  expect_logged(b, Fault::kStopTimeout);
}

TEST(SafetyFilter, ResetNeedsEveryCauseClearedAndNeverRestartsMotion) {
  Bench b;
  settle(b);
  b.fb.drive[1].stop_input = true;
  b.filter->request_stop(StopSource::kLcm);
  EXPECT_EQ(b.step(), SafetyState::kSto);
  EXPECT_EQ(b.arm(), ArmStatus::kLatched);  // no start while latched
  // The circuit is still open: the reset is refused after reset_fault_cycles.
  b.filter->request_reset();
  for (int k = 0; k < b.cfg.watchdogs.reset_fault_cycles; ++k)
    EXPECT_EQ(b.step(), SafetyState::kSto);
  const FaultEvent* refused = b.find(EventKind::kResetRefused);
  ASSERT_NE(refused, nullptr);
  EXPECT_EQ(refused->blocking, bit(Fault::kEstopInput));
  // Closed again: the reset is accepted, the LCM request (momentary) clears with it.
  b.fb.drive[1].stop_input = false;
  b.filter->request_reset();
  EXPECT_EQ(b.step(), SafetyState::kDisabled);
  EXPECT_NE(b.find(EventKind::kResetAccepted), nullptr);
  EXPECT_EQ(b.filter->report().latched, 0u);
  // The controller still asks for torque and enable: nothing gets through until arm().
  b.in.command.torque = {3, 3, 3, 3};
  b.in.command.request = DriveRequest::kEnable;
  for (int k = 0; k < 100; ++k) {
    EXPECT_EQ(b.step(), SafetyState::kDisabled);
    EXPECT_EQ(b.out.request, DriveRequest::kDisable);
    EXPECT_EQ(b.max_abs_out(), 0.0);
  }
  EXPECT_EQ(b.arm(), ArmStatus::kOk);
  EXPECT_EQ(b.step(), SafetyState::kOperational);
}

TEST(SafetyFilter, ResetSendsFaultResetToFaultedDrives) {
  Bench b;
  settle(b);
  b.fb.drive[2].state = DriveState::kFault;
  EXPECT_EQ(b.step(), SafetyState::kSto);
  b.filter->request_reset();
  EXPECT_EQ(b.step(), SafetyState::kSto);
  EXPECT_EQ(b.out.request, DriveRequest::kFaultReset);  // CiA 402 transition 15
  EXPECT_EQ(b.max_abs_out(), 0.0);
  b.fb.drive[2].state = DriveState::kDisabled;  // the drive left Fault
  EXPECT_EQ(b.step(), SafetyState::kDisabled);
  EXPECT_EQ(b.out.request, DriveRequest::kDisable);
}

TEST(SafetyFilter, ResetDuringSs1IsRefused) {
  Bench b;
  settle(b);
  b.fb.drive[0].position += 0.5 * b.period;  // moving: no standstill yet
  b.filter->request_stop(StopSource::kCli);
  EXPECT_EQ(b.step(), SafetyState::kSs1);
  b.filter->request_reset();
  b.fb.drive[0].position += 0.5 * b.period;
  EXPECT_EQ(b.step(), SafetyState::kSs1);
  EXPECT_NE(b.find(EventKind::kResetRefused), nullptr);
}

TEST(WriteGuard, SkippedOrBypassedCheckTakesTorqueOff) {
  struct Recorder final : drivers::ActuatorSet {
    int size() const noexcept override { return 4; }
    drivers::IoStatus read(drivers::ActuatorFeedback&) noexcept override {
      return drivers::IoStatus::kOk;
    }
    drivers::IoStatus write(const drivers::ActuatorCommand& c) noexcept override {
      last = c;
      return drivers::IoStatus::kOk;
    }
    drivers::ActuatorCommand last;
  } io;
  Bench b;
  settle(b);
  WriteGuard guard(*b.filter);
  b.in.command.torque = {2, 2, 2, 2};
  b.step();
  guard.write(io, b.out);
  EXPECT_EQ(io.last.torque[0], 2.0);
  EXPECT_EQ(guard.trips(), 0u);
  // Skipped: a second write without a check in between.
  guard.write(io, b.out);
  EXPECT_EQ(guard.trips(), 1u);
  EXPECT_EQ(io.last.request, DriveRequest::kDisable);
  EXPECT_EQ(io.last.torque[0], 0.0);
  EXPECT_EQ(b.step(), SafetyState::kSto);  // latched at the next check
  expect_logged(b, Fault::kSafetyCheckMissed);
  // Bypassed: a command other than the filter's output.
  Bench c;
  settle(c);
  WriteGuard g2(*c.filter);
  c.step();
  drivers::ActuatorCommand forged = c.out;
  forged.torque[1] = 50.0;
  g2.write(io, forged);
  EXPECT_EQ(g2.trips(), 1u);
  EXPECT_EQ(io.last.torque[1], 0.0);
  EXPECT_EQ(io.last.request, DriveRequest::kDisable);
}

TEST(SafetyFilter, TelemetryStateCodesFollowRobotStateT) {
  SafetyReport r;
  EXPECT_EQ(telemetry_state(r), 0);
  r.state = SafetyState::kOperational;
  EXPECT_EQ(telemetry_state(r), 1);
  r.state = SafetyState::kSs1;
  EXPECT_EQ(telemetry_state(r), 2);
  r.state = SafetyState::kSto;
  r.latched = bit(Fault::kTrackingError);
  EXPECT_EQ(telemetry_state(r), 3);
  r.latched |= bit(Fault::kDriveLost);
  EXPECT_EQ(telemetry_state(r), 5);
  r.latched |= bit(Fault::kEstopInput);
  EXPECT_EQ(telemetry_state(r), 4);
}

TEST(SafetyFilter, UpdateAllocatesNothing) {
  Bench b;
  settle(b);
  const long before = dualv::test::allocation_count();
  for (int k = 0; k < 20000; ++k) {
    b.in.command.torque = {std::sin(k * 1e-2), 0.0, (k % 1000 == 500) ? 1e9 : 0.0, 0.0};
    b.step();
    if (b.filter->state() == SafetyState::kSto) {
      b.filter->request_reset();
      b.step();
      b.filter->arm(b.fb, b.in.time_ns);
    }
    if (b.filter->state() == SafetyState::kSs1 && k % 7 == 0)
      b.fb.drive[0].stop_input = true;
    else
      b.fb.drive[0].stop_input = false;
    FaultEvent e;
    while (b.filter->log().try_pop(e)) {
    }
  }
  EXPECT_EQ(dualv::test::allocation_count() - before, 0);
}

}  // namespace
}  // namespace dualv::safety::test
