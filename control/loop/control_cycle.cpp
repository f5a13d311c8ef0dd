#include "control/loop/control_cycle.hpp"

#include <fmt/format.h>

#include <stdexcept>

#include "control/model/kinematics.hpp"

namespace dualv::control {

const char* to_string(CyclePhase p) noexcept {
  switch (p) {
    case CyclePhase::kEnabling:
      return "enabling";
    case CyclePhase::kRunning:
      return "running";
    case CyclePhase::kHolding:
      return "holding";
    case CyclePhase::kStopped:
      return "stopped";
  }
  return "unknown";
}

const char* to_string(CycleStatus s) noexcept {
  switch (s) {
    case CycleStatus::kOk:
      return "ok";
    case CycleStatus::kIoError:
      return "io error";
    case CycleStatus::kEstimateFailed:
      return "estimate failed";
    case CycleStatus::kControlFailed:
      return "control failed";
    case CycleStatus::kEnableTimeout:
      return "enable timeout";
    case CycleStatus::kSafetyStop:
      return "safety stop";
  }
  return "unknown";
}

ControlCycle::ControlCycle(const model::Model& model, const ControlSetup& setup,
                           const CycleConfig& config)
    : model_(&model),
      config_(config),
      estimator_(model, setup.estimator, config.period),
      controller_(model, setup.controller),
      q_meas_(model::JointVector::Zero(model.n)),
      safety_(model, config.safety, config.period),
      guard_(safety_) {}

double ControlCycle::program_duration() const noexcept {
  return sequencer_ ? sequencer_->duration() : 0.0;
}

void ControlCycle::read_pose(drivers::ActuatorSet& io, drivers::ActuatorFeedback& fb,
                             model::JointVector& q, model::Pose& X) {
  if (io.size() != model_->n)
    throw std::runtime_error(fmt::format(
        "the actuator set has {} drives but the model has {} chains", io.size(), model_->n));
  const drivers::IoStatus s = io.read(fb);
  if (s == drivers::IoStatus::kBusError || s == drivers::IoStatus::kNotReady)
    throw std::runtime_error("cannot read the drives' positions at start-up");
  q.resize(model_->n);
  for (int i = 0; i < model_->n; ++i) q[i] = fb.drive[i].position;
  model::Data data(*model_);
  const model::FkResult fk = model::forward_kinematics(*model_, data, q, model_->home, X);
  if (fk.status != model::Status::kOk)
    throw std::runtime_error(fmt::format(
        "cannot find the plate pose from the joint angles (forward kinematics: {}, residual {:.3g} "
        "rad): check the encoder offsets and that the robot is near its home pose",
        model::to_string(fk.status), fk.residual));
}

void ControlCycle::arm(const drivers::ActuatorFeedback& fb, const model::JointVector& q,
                       const model::Pose& X) {
  const safety::ArmStatus armed = safety_.arm(
      fb, static_cast<std::int64_t>(static_cast<double>(cycle_) * config_.period * 1e9));
  if (armed != safety::ArmStatus::kOk)
    throw std::runtime_error(fmt::format("cannot start: safety: {}", safety::to_string(armed)));
  estimator_.reset(q, X);
  phase_ = CyclePhase::kEnabling;
  cycle_ = 0;
  enabling_cycles_ = 0;
  t_ = 0.0;
  stream_fresh_ = false;
}

void ControlCycle::start(drivers::ActuatorSet& io, const trajectory::Program& program,
                         const trajectory::RebaseOptions& rebase) {
  drivers::ActuatorFeedback fb;
  model::JointVector q;
  model::Pose X;
  read_pose(io, fb, q, X);
  // Arm the safety filter last: nothing above may leave it armed on a failed start.
  std::optional<trajectory::Sequencer> sequencer;
  sequencer.emplace(*model_, trajectory::rebase(program, X, rebase));
  arm(fb, q, X);
  stream_.reset();
  sequencer_ = std::move(sequencer);
}

void ControlCycle::start_streaming(drivers::ActuatorSet& io,
                                   const trajectory::StreamingLimits& limits,
                                   const trajectory::Workspace& workspace) {
  drivers::ActuatorFeedback fb;
  model::JointVector q;
  model::Pose X;
  read_pose(io, fb, q, X);
  std::optional<trajectory::StreamingReference> stream;
  stream.emplace(*model_, limits, workspace, config_.period);
  stream->reset(X);  // from the actual pose, at rest: starting a stream never moves the robot
  arm(fb, q, X);
  sequencer_.reset();
  stream_ = std::move(stream);
}

trajectory::TargetStatus ControlCycle::stream_setpoint(const model::Pose& X) noexcept {
  if (!stream_ || phase_ == CyclePhase::kStopped) return trajectory::TargetStatus::kNotActive;
  const trajectory::TargetStatus s = stream_->set_target(X);
  if (s == trajectory::TargetStatus::kAccepted) stream_fresh_ = true;
  return s;
}

void ControlCycle::end_stream() noexcept {
  if (stream_) stream_->hold();
}

CycleStatus ControlCycle::step(drivers::ActuatorSet& io, CycleRecord& rec) noexcept {
  const int n = model_->n;
  rec.cycle = cycle_++;
  rec.status = CycleStatus::kOk;
  rec.command.n = n;
  rec.command.torque.fill(0.0);
  rec.command.request = drivers::DriveRequest::kHold;

  const drivers::IoStatus io_status = io.read(rec.feedback);
  for (int i = 0; i < n; ++i) q_meas_[i] = rec.feedback.drive[i].position;
  if (io_status == drivers::IoStatus::kBusError) rec.status = CycleStatus::kIoError;
  if (estimator_.update(q_meas_) != EstimateStatus::kOk && rec.status == CycleStatus::kOk)
    rec.status = CycleStatus::kEstimateFailed;
  rec.est = estimator_.estimate();

  if (!has_reference()) {
    rec.status = CycleStatus::kControlFailed;
    finish(io, rec, io_status);
    return rec.status;
  }

  if (phase_ == CyclePhase::kEnabling) {
    bool all_enabled = true;
    for (int i = 0; i < n; ++i)
      all_enabled = all_enabled && rec.feedback.drive[i].state == drivers::DriveState::kEnabled;
    if (all_enabled) {
      phase_ = CyclePhase::kRunning;
    } else {
      // Target torque 0 until every drive is enabled: enabling never moves the robot.
      rec.command.request = drivers::DriveRequest::kEnable;
      ++enabling_cycles_;
      if (enabling_cycles_ * config_.period > config_.enable_timeout)
        rec.status = CycleStatus::kEnableTimeout;
    }
  }

  rec.phase = phase_;
  rec.t = t_;
  const bool moving = phase_ == CyclePhase::kRunning || phase_ == CyclePhase::kHolding;
  const trajectory::SampleStatus ss =
      stream_ ? stream_->step(moving, rec.ref) : sequencer_->sample(t_, rec.ref);
  if (stream_ && phase_ == CyclePhase::kRunning && !stream_->active())
    phase_ = CyclePhase::kHolding;
  if (phase_ == CyclePhase::kRunning && ss == trajectory::SampleStatus::kFinished)
    phase_ = CyclePhase::kHolding;

  if (phase_ == CyclePhase::kRunning || phase_ == CyclePhase::kHolding) {
    const ControlStatus cs = controller_.update(rec.ref, rec.est, rec.control);
    if (rec.status == CycleStatus::kOk && cs != ControlStatus::kOk)
      rec.status = CycleStatus::kControlFailed;
    if (rec.status == CycleStatus::kOk)
      for (int i = 0; i < n; ++i) rec.command.torque[i] = rec.control.tau[i];
    t_ += config_.period;
  }
  finish(io, rec, io_status);
  return rec.status;
}

// The safety filter decides what is written (SafetyFilter::update), the guard writes it.
CycleStatus ControlCycle::finish(drivers::ActuatorSet& io, CycleRecord& rec,
                                 drivers::IoStatus io_status) noexcept {
  if (hook_) hook_(hook_context_, rec.cycle, rec.command);
  safety::SafetyInput in;
  in.cycle = rec.cycle;
  in.time_ns = static_cast<std::int64_t>(static_cast<double>(rec.cycle) * config_.period * 1e9);
  in.io_status = io_status;
  in.command = rec.command;
  in.pose_valid = rec.est.status == EstimateStatus::kOk;
  in.X = rec.est.X;
  in.tracking =
      has_reference() && (phase_ == CyclePhase::kRunning || phase_ == CyclePhase::kHolding);
  in.X_d = rec.ref.cartesian.X;
  in.deadline_missed = deadline_missed_;
  in.consecutive_deadline_misses = consecutive_misses_;
  // The watchdog runs while a stream is followed (not while the drives enable: the sender
  // cannot know when that ends); end_stream() turns it off.
  in.streaming = streaming_ || (stream_ && stream_->active() && phase_ == CyclePhase::kRunning);
  in.stream_fresh = stream_fresh_;
  stream_fresh_ = false;
  const safety::SafetyState st = safety_.update(rec.feedback, in, rec.command);
  if (st != safety::SafetyState::kOperational) {
    if (has_reference()) phase_ = CyclePhase::kStopped;
    rec.phase = phase_;
    if (rec.status == CycleStatus::kOk) rec.status = CycleStatus::kSafetyStop;
  }
  rec.safety = safety_.report();
  guard_.write(io, rec.command);
  return rec.status;
}

}  // namespace dualv::control
