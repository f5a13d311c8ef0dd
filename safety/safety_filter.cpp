#include "safety/safety_filter.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "control/model/solve_spd3.hpp"

namespace dualv::safety {

using drivers::DriveRequest;
using drivers::DriveState;

const char* to_string(SafetyState s) noexcept {
  switch (s) {
    case SafetyState::kDisabled:
      return "disabled";
    case SafetyState::kOperational:
      return "operational";
    case SafetyState::kSs1:
      return "SS1";
    case SafetyState::kSto:
      return "STO";
  }
  return "unknown";
}

const char* to_string(ArmStatus s) noexcept {
  switch (s) {
    case ArmStatus::kOk:
      return "ok";
    case ArmStatus::kLatched:
      return "a stop is latched: reset it first";
    case ArmStatus::kInvalidFeedback:
      return "invalid feedback";
  }
  return "unknown";
}

std::int8_t telemetry_state(const SafetyReport& r) noexcept {
  constexpr FaultSet kEstop = bit(Fault::kEstopLcm) | bit(Fault::kEstopSignal) |
                              bit(Fault::kEstopCli) | bit(Fault::kEstopInput);
  constexpr FaultSet kDrive =
      bit(Fault::kDriveLost) | bit(Fault::kDriveFault) | bit(Fault::kBusError);
  switch (r.state) {
    case SafetyState::kDisabled:
      return 0;
    case SafetyState::kOperational:
      return 1;
    case SafetyState::kSs1:
      return 2;
    case SafetyState::kSto:
      if (r.latched & kEstop) return 4;
      if (r.latched & kDrive) return 5;
      return 3;
  }
  return 5;
}

CycleLimits cycle_limits(const SafetyConfig& c, double period) noexcept {
  auto cycles = [period](double t) {
    return static_cast<std::int32_t>(std::max(1.0, std::ceil(t / period - 1e-9)));
  };
  CycleLimits l;
  l.ss1_max = cycles(c.ss1.max_time);
  l.standstill = std::max<std::int32_t>(1, cycles(c.ss1.standstill_time));
  l.stream_timeout = cycles(c.watchdogs.command_stream_timeout);
  l.torque_step = c.torque.max_rate * period;
  return l;
}

bool limit_torque(const double* in, const double* prev, int n, double max, double max_step,
                  double* out) noexcept {
  bool changed = false;
  for (int i = 0; i < n; ++i) {
    const double p = std::clamp(std::isfinite(prev[i]) ? prev[i] : 0.0, -max, max);
    double v = in[i];
    if (!std::isfinite(v)) {
      v = p;
      changed = true;
    }
    const double lo = std::max(-max, p - max_step);
    const double hi = std::min(max, p + max_step);
    const double c = std::clamp(v, lo, hi);
    if (c != v) changed = true;
    out[i] = c;
  }
  return changed;
}

SafetyFilter::SafetyFilter(const model::Model& model, const SafetyConfig& config, double period_s)
    : model_(&model),
      config_(config),
      period_(period_s),
      limits_(cycle_limits(config, period_s)),
      n_(model.n),
      data_(model) {
  const std::string problems = validate(config);
  if (!problems.empty()) throw std::invalid_argument("safety configuration: " + problems);
  if (!(period_s > 0.0)) throw std::invalid_argument("safety: the control period must be > 0");
  if (n_ < 1 || n_ > drivers::kMaxDrives)
    throw std::invalid_argument(fmt::format("safety: {} drives (1..{})", n_, drivers::kMaxDrives));
  last_out_.n = n_;
  last_out_.request = DriveRequest::kDisable;
}

void SafetyFilter::set_limits_for_test(const SafetyConfig& config) {
  const std::string problems = validate(config);
  if (!problems.empty()) throw std::invalid_argument("safety limit test: " + problems);
  config_ = config;
  limits_ = cycle_limits(config, period_);
}

void SafetyFilter::Detection::add(Fault f, int drive_index, double v, double lim,
                                  int latency_cycles) noexcept {
  const auto i = static_cast<std::size_t>(f);
  if (set & bit(f)) {
    // Keep the worst value of several drives.
    if (std::abs(v) > std::abs(value[i])) {
      value[i] = v;
      drive[i] = static_cast<std::int16_t>(drive_index);
    }
    return;
  }
  set |= bit(f);
  drive[i] = static_cast<std::int16_t>(drive_index);
  value[i] = v;
  limit[i] = lim;
  latency[i] = latency_cycles;
}

ArmStatus SafetyFilter::arm(const drivers::ActuatorFeedback& fb, std::int64_t time_ns) noexcept {
  latch_.latch(latch_.take_stop_requests() |
               (check_missed_.exchange(false, std::memory_order_acq_rel)
                    ? bit(Fault::kSafetyCheckMissed)
                    : 0));
  if (latch_.any()) return ArmStatus::kLatched;
  for (int i = 0; i < n_; ++i)
    if (!std::isfinite(fb.drive[static_cast<std::size_t>(i)].position))
      return ArmStatus::kInvalidFeedback;
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    q_prev_[k] = fb.drive[k].position;
    q_prev_valid_[k] = true;
    since_fresh_[k] = 0;
    q_dot_[k] = 0.0;
    tau_prev_[k] = 0.0;
  }
  stream_age_ = 0;
  standstill_count_ = 0;
  reset_cycles_left_ = 0;
  all_enabled_seen_ = false;
  report_.state = SafetyState::kOperational;
  report_.stop_cycles = 0;
  log_event(EventKind::kArmed, Fault::kCount, Reaction::kWarn, nullptr, 0, time_ns);
  return ArmStatus::kOk;
}

void SafetyFilter::disarm() noexcept {
  if (report_.state == SafetyState::kOperational) report_.state = SafetyState::kDisabled;
}

void SafetyFilter::monitor(const drivers::ActuatorFeedback& fb, const SafetyInput& in,
                           Detection& d) noexcept {
  const SafetyConfig& c = config_;
  // Idle (kDisabled: 0 N m, drives disabled) the loop keeps running (control/loop/executor.hpp):
  // drives, bus, e-stop inputs, feedback and timing are watched, but the motion limits (joint
  // and plate velocity, workspace, singularity, tracking) apply only while the motors may
  // move the robot: a robot pushed by hand while disabled is not a fault of the controller.
  const bool powered = report_.state != SafetyState::kDisabled;
  // --- Drives and bus ----------------------------------------------------------------
  if (in.io_status == drivers::IoStatus::kBusError) d.add(Fault::kBusError);
  if (fb.n != n_) d.add(Fault::kInvalidState, -1, fb.n, n_);
  for (int i = 0; i < n_; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const drivers::DriveFeedback& df = fb.drive[k];
    if (df.stop_input) d.add(Fault::kEstopInput, i);
    if (df.state == DriveState::kOffline) d.add(Fault::kDriveLost, i);
    // A drive in Fault, or one that reports an active emergency (EMCY not yet cleared by an
    // 0000h error reset, CiA 301 7.2.7) even before its statusword shows Fault.
    if (df.state == DriveState::kFault || df.last_emcy != 0)
      d.add(Fault::kDriveFault, i, df.last_emcy);
    // A drive that leaves Operation enabled on its own while the program runs (its quick
    // stop, its STO input, a transition it made itself): the others must not go on alone.
    if (report_.state == SafetyState::kOperational && all_enabled_seen_ &&
        (df.state == DriveState::kDisabled || df.state == DriveState::kQuickStop))
      d.add(Fault::kDriveFault, i, static_cast<double>(df.state));
    // Stale feedback: k cycles without a fresh position (the first stale cycle is the
    // first bad sample: latency k - 1).
    if (df.fresh && std::isfinite(df.position)) {
      const double elapsed = period_ * static_cast<double>(since_fresh_[k] + 1);
      if (q_prev_valid_[k]) {
        const double dq = df.position - q_prev_[k];
        if (std::abs(dq) > c.max_encoder_jump) {
          d.add(Fault::kEncoderJump, i, dq, c.max_encoder_jump);
          q_dot_[k] = 0.0;  // no velocity from a jump
        } else {
          q_dot_[k] = dq / elapsed;
        }
      }
      q_prev_[k] = df.position;
      q_prev_valid_[k] = true;
      since_fresh_[k] = 0;
    } else {
      if (!std::isfinite(df.position)) d.add(Fault::kInvalidState, i);
      if (since_fresh_[k] < INT32_MAX) ++since_fresh_[k];
      if (since_fresh_[k] >= c.watchdogs.stale_feedback_cycles)
        d.add(Fault::kStaleFeedback, i, since_fresh_[k], c.watchdogs.stale_feedback_cycles,
              c.watchdogs.stale_feedback_cycles - 1);
    }
    if (powered && std::abs(q_dot_[k]) > c.max_joint_velocity)
      d.add(Fault::kJointVelocity, i, q_dot_[k], c.max_joint_velocity);
  }

  if (report_.state == SafetyState::kOperational && !all_enabled_seen_) {
    bool all = fb.n == n_;
    for (int i = 0; i < n_; ++i)
      all = all && fb.drive[static_cast<std::size_t>(i)].state == DriveState::kEnabled;
    all_enabled_seen_ = all;
  }

  // --- Plate: workspace, singularity, plate velocity, tracking error ----------------
  const bool pose_ok = in.pose_valid && in.X.allFinite();
  if (!powered) {
    // idle: no motion limits (above)
  } else if (!pose_ok) {
    d.add(Fault::kInvalidState);
  } else {
    const model::Pose& X = in.X;
    if (!c.workspace.x.contains(X.x()))
      d.add(Fault::kWorkspace, -1, X.x(),
            X.x() < c.workspace.x.lo ? c.workspace.x.lo : c.workspace.x.hi);
    else if (!c.workspace.y.contains(X.y()))
      d.add(Fault::kWorkspace, -1, X.y(),
            X.y() < c.workspace.y.lo ? c.workspace.y.lo : c.workspace.y.hi);
    else if (!c.workspace.theta.contains(X.z()))
      d.add(Fault::kWorkspace, -1, X.z(),
            X.z() < c.workspace.theta.lo ? c.workspace.theta.lo : c.workspace.theta.hi);
    const model::Status ks =
        model::update_velocity_kinematics(*model_, data_, X, model::Twist::Zero());
    if (ks == model::Status::kOk) {
      const model::SingularityMeasures sm = model::singularity_measures(*model_, data_);
      if (sm.parallel < c.min_parallel_singularity)
        d.add(Fault::kSingularity, -1, sm.parallel, c.min_parallel_singularity);
      else if (sm.min_serial < c.min_serial_singularity)
        d.add(Fault::kSingularity, -1, sm.min_serial, c.min_serial_singularity);
      // Plate twist from the joint velocities: least squares of q_dot = Jm X_dot.
      model::JointVector qd(n_);
      for (int i = 0; i < n_; ++i) qd[i] = q_dot_[static_cast<std::size_t>(i)];
      model::Ldlt3 ldlt;
      model::Twist Xd = model::Twist::Constant(std::numeric_limits<double>::quiet_NaN());
      if (ldlt.factor(data_.Jm.transpose() * data_.Jm)) ldlt.solve(data_.Jm.transpose() * qd, Xd);
      const double v = std::hypot(Xd.x(), Xd.y());
      if (std::isfinite(v) && v > c.max_plate_velocity)
        d.add(Fault::kPlateVelocity, -1, v, c.max_plate_velocity);
      else if (std::isfinite(Xd.z()) && std::abs(Xd.z()) > c.max_plate_angular_velocity)
        d.add(Fault::kPlateVelocity, -1, Xd.z(), c.max_plate_angular_velocity);
    } else if (ks == model::Status::kSerialSingular || ks == model::Status::kParallelSingular) {
      d.add(Fault::kSingularity);
    } else if (ks == model::Status::kUnreachable) {
      d.add(Fault::kWorkspace);
    } else {
      d.add(Fault::kInvalidState);
    }
    if (in.tracking) {
      if (!in.X_d.allFinite()) {
        d.add(Fault::kNonFiniteCommand);
      } else {
        const double e = std::hypot(in.X_d.x() - X.x(), in.X_d.y() - X.y());
        const double et = in.X_d.z() - X.z();
        if (e > c.max_tracking_error)
          d.add(Fault::kTrackingError, -1, e, c.max_tracking_error);
        else if (std::abs(et) > c.max_tracking_error_angle)
          d.add(Fault::kTrackingError, -1, et, c.max_tracking_error_angle);
      }
    }
  }

  // --- The controller's command (only while it is the one that gets through) ---------
  if (report_.state == SafetyState::kOperational) {
    for (int i = 0; i < n_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const double t = in.command.torque[k];
      if (!std::isfinite(t)) {
        d.add(Fault::kNonFiniteCommand, i);
      } else {
        if (std::abs(t) > c.torque.max) d.add(Fault::kTorqueLimit, i, t, c.torque.max);
        const double step = t - tau_prev_[k];
        if (std::abs(step) > limits_.torque_step * (1.0 + 1e-12))
          d.add(Fault::kTorqueRate, i, step / period_, c.torque.max_rate);
      }
    }
  }

  // --- Watchdogs ---------------------------------------------------------------------
  if (in.deadline_missed && in.consecutive_deadline_misses <= 1) d.add(Fault::kDeadlineMiss);
  if (in.consecutive_deadline_misses >= c.watchdogs.max_consecutive_deadline_misses)
    d.add(Fault::kDeadlineMisses, -1, in.consecutive_deadline_misses,
          c.watchdogs.max_consecutive_deadline_misses,
          c.watchdogs.max_consecutive_deadline_misses - 1);
  if (in.streaming && report_.state == SafetyState::kOperational) {
    stream_age_ = in.stream_fresh ? 0 : stream_age_ + 1;
    if (stream_age_ >= limits_.stream_timeout)
      d.add(Fault::kCommandStreamStale, -1, stream_age_ * period_,
            config_.watchdogs.command_stream_timeout, limits_.stream_timeout - 1);
  } else {
    stream_age_ = 0;
  }
  if (check_missed_.exchange(false, std::memory_order_acq_rel)) d.add(Fault::kSafetyCheckMissed);
}

bool SafetyFilter::at_standstill() const noexcept {
  for (int i = 0; i < n_; ++i)
    if (!(std::abs(q_dot_[static_cast<std::size_t>(i)]) < config_.ss1.standstill_velocity))
      return false;
  return true;
}

void SafetyFilter::log_event(EventKind kind, Fault fault, Reaction reaction, const Detection* d,
                             FaultSet blocking, std::int64_t time_ns) noexcept {
  FaultEvent e;
  e.cycle = cycle_;
  e.time_ns = time_ns;
  e.kind = kind;
  e.fault = fault;
  e.reaction = reaction;
  e.blocking = blocking;
  if (d && fault != Fault::kCount) {
    const auto i = static_cast<std::size_t>(fault);
    e.drive = d->drive[i];
    e.latency_cycles = d->latency[i];
    e.value = d->value[i];
    e.limit = d->limit[i];
  }
  e.n = static_cast<std::int16_t>(n_);
  e.torque = last_out_.torque;  // filled with this cycle's output before logging
  log_.record(e);
}

void SafetyFilter::enter_sto(std::int64_t) noexcept {
  report_.state = SafetyState::kSto;
  standstill_count_ = 0;
}

SafetyState SafetyFilter::update(const drivers::ActuatorFeedback& fb, const SafetyInput& in,
                                 drivers::ActuatorCommand& out) noexcept {
  ++own_cycles_;
  cycle_ = in.cycle >= 0 ? in.cycle : own_cycles_;
  report_.torque_limited = false;
  // 1. External requests.
  Detection d;
  const FaultSet requests = latch_.take_stop_requests();
  for (int i = 0; i < kFaultCount; ++i)
    if ((requests >> i) & 1u) d.add(static_cast<Fault>(i));
  const bool reset_requested = latch_.take_reset_request();

  // 2. Monitors.
  monitor(fb, in, d);
  report_.active = d.set;

  // 3. Latch what stops; warnings are only logged.
  FaultSet stopping = 0;
  for (int i = 0; i < kFaultCount; ++i)
    if (((d.set >> i) & 1u) && kFaultTable[static_cast<std::size_t>(i)].reaction != Reaction::kWarn)
      stopping |= FaultSet{1} << i;
  const FaultSet fresh = latch_.latch(stopping);
  report_.detected = fresh;

  // 4. State machine.
  const Reaction worst = strongest(latch_.latched());
  SafetyState& st = report_.state;
  if (latch_.any()) {
    if (worst == Reaction::kSto || st == SafetyState::kDisabled) {
      if (st != SafetyState::kSto) enter_sto(in.time_ns);
    } else if (worst == Reaction::kSs1 && st == SafetyState::kOperational) {
      st = SafetyState::kSs1;
      report_.stop_cycles = 0;
      standstill_count_ = 0;
    }
  }
  bool stop_reached = false, stop_timeout = false;
  if (st == SafetyState::kSs1) {
    ++report_.stop_cycles;
    standstill_count_ = at_standstill() ? standstill_count_ + 1 : 0;
    if (standstill_count_ >= limits_.standstill) {
      enter_sto(in.time_ns);
      stop_reached = true;
    } else if (report_.stop_cycles >= limits_.ss1_max) {
      latch_.latch(bit(Fault::kStopTimeout));
      enter_sto(in.time_ns);
      stop_timeout = true;
    }
  }

  // Reset: only from a completed stop (STO) or with nothing latched; drives in Fault get a
  // CiA 402 fault reset (rising edge of controlword bit 7) for up to reset_fault_cycles.
  FaultSet reset_blocking = 0;
  bool reset_accepted = false, reset_refused = false;
  if (reset_requested) {
    if (st == SafetyState::kSs1) {
      reset_refused = true;
      reset_blocking = latch_.latched();
    } else if (st == SafetyState::kSto) {
      reset_cycles_left_ = config_.watchdogs.reset_fault_cycles;
    }
  }
  bool fault_reset_request = false;
  if (reset_cycles_left_ > 0 && st == SafetyState::kSto) {
    const FaultSet b = latch_.try_reset(d.set);
    if (b == 0) {
      reset_accepted = true;
      reset_cycles_left_ = 0;
      st = SafetyState::kDisabled;
      report_.stop_cycles = 0;
    } else {
      fault_reset_request = (b & bit(Fault::kDriveFault)) != 0;
      if (--reset_cycles_left_ == 0) {
        reset_refused = true;
        reset_blocking = b;
      }
    }
  }
  report_.reset_pending = reset_cycles_left_ > 0;

  // 5. The command.
  out.n = n_;
  out.torque.fill(0.0);
  switch (st) {
    case SafetyState::kOperational: {
      report_.torque_limited =
          limit_torque(in.command.torque.data(), tau_prev_.data(), n_, config_.torque.max,
                       limits_.torque_step, out.torque.data());
      out.request = in.command.request;
      break;
    }
    case SafetyState::kSs1: {
      std::array<double, drivers::kMaxDrives> brake{};
      for (int i = 0; i < n_; ++i) {
        const auto k = static_cast<std::size_t>(i);
        brake[k] = std::clamp(-config_.ss1.damping * q_dot_[k], -config_.ss1.max_torque,
                              config_.ss1.max_torque);
      }
      limit_torque(brake.data(), tau_prev_.data(), n_, config_.torque.max, limits_.torque_step,
                   out.torque.data());
      out.request = DriveRequest::kHold;  // stay enabled: the drives brake under power
      break;
    }
    case SafetyState::kSto:
      out.request = fault_reset_request ? DriveRequest::kFaultReset : DriveRequest::kDisable;
      break;
    case SafetyState::kDisabled:
      out.request = DriveRequest::kDisable;
      break;
  }
  for (int i = 0; i < n_; ++i)
    tau_prev_[static_cast<std::size_t>(i)] = out.torque[static_cast<std::size_t>(i)];
  last_out_ = out;

  // 6. Log (with the torque sent in this cycle).
  for (int i = 0; i < kFaultCount; ++i) {
    const auto f = static_cast<Fault>(i);
    if (((fresh >> i) & 1u) || ((d.set & ~stopping) & bit(f)))
      log_event(EventKind::kFault, f, reaction_of(f), &d, 0, in.time_ns);
  }
  if (stop_timeout)
    log_event(EventKind::kFault, Fault::kStopTimeout, Reaction::kSto, nullptr, 0, in.time_ns);
  if (stop_reached || stop_timeout)
    log_event(EventKind::kStopReached, Fault::kCount, Reaction::kSto, nullptr, 0, in.time_ns);
  if (reset_accepted)
    log_event(EventKind::kResetAccepted, Fault::kCount, Reaction::kWarn, nullptr, 0, in.time_ns);
  if (reset_refused)
    log_event(EventKind::kResetRefused, Fault::kCount, Reaction::kWarn, nullptr, reset_blocking,
              in.time_ns);

  report_.latched = latch_.latched();
  report_.checks = checks_.fetch_add(1, std::memory_order_acq_rel) + 1;
  return st;
}

drivers::IoStatus WriteGuard::write(drivers::ActuatorSet& io,
                                    const drivers::ActuatorCommand& command) noexcept {
  const std::uint64_t checks = filter_->checks();
  const drivers::ActuatorCommand& expected = filter_->last_output();
  bool same =
      checks != last_checks_ && command.n == expected.n && command.request == expected.request;
  for (int i = 0; same && i < command.n && i < drivers::kMaxDrives; ++i)
    same =
        command.torque[static_cast<std::size_t>(i)] == expected.torque[static_cast<std::size_t>(i)];
  last_checks_ = checks;
  if (same) return io.write(command);
  // The safety check did not run for this write, or its output was changed: STO.
  ++trips_;
  filter_->report_check_missed();
  drivers::ActuatorCommand off;
  off.n = io.size();
  off.request = drivers::DriveRequest::kDisable;
  return io.write(off);
}

}  // namespace dualv::safety
