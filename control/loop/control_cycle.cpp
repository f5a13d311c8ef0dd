#include "control/loop/control_cycle.hpp"

#include <fmt/format.h>

#include <cmath>
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
    case CyclePhase::kIdle:
      return "idle";
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
    case CycleStatus::kNotActivated:
      return "not activated";
  }
  return "unknown";
}

ControlCycle::ControlCycle(const model::Model& model, const ControlSetup& setup,
                           const CycleConfig& config)
    : model_(&model),
      config_(config),
      estimator_(model, setup.estimator, config.period),
      controller_(model, setup.controller),
      seed_data_(model),
      q_meas_(model::JointVector::Zero(model.n)),
      safety_(model, config.safety, config.period),
      guard_(safety_) {}

double ControlCycle::program_duration() const noexcept {
  const trajectory::Sequencer* s = sequencer();
  return s ? s->duration() : 0.0;
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

safety::ArmStatus ControlCycle::activate(PreparedReference& ref,
                                         const drivers::ActuatorFeedback& fb) noexcept {
  const bool was_operational = safety_.state() == safety::SafetyState::kOperational;
  if (!was_operational) {
    const safety::ArmStatus armed = safety_.arm(
        fb, static_cast<std::int64_t>(static_cast<double>(cycle_) * config_.period * 1e9));
    if (armed != safety::ArmStatus::kOk) return armed;
  }
  bool all_enabled = was_operational;
  for (int i = 0; i < model_->n; ++i)
    all_enabled = all_enabled && fb.drive[i].state == drivers::DriveState::kEnabled;
  controller_.config().projection = ref.projection;
  controller_.config().feedforward = ref.feedforward;
  active_ = &ref;
  phase_ = all_enabled ? CyclePhase::kRunning : CyclePhase::kEnabling;
  enabling_cycles_ = 0;
  t_ = 0.0;
  stream_fresh_ = false;
  return safety::ArmStatus::kOk;
}

void ControlCycle::deactivate() noexcept {
  active_ = nullptr;
  phase_ = CyclePhase::kIdle;
  safety_.disarm();
}

void ControlCycle::activate_owned(std::unique_ptr<PreparedReference> ref,
                                  const drivers::ActuatorFeedback& fb, const model::JointVector& q,
                                  const model::Pose& X) {
  // activate() changes nothing when refused: the reference followed so far stays.
  const safety::ArmStatus armed = activate(*ref, fb);
  if (armed != safety::ArmStatus::kOk)
    throw std::runtime_error(fmt::format("cannot start: safety: {}", safety::to_string(armed)));
  owned_ = std::move(ref);
  estimator_.reset(q, X);
  seeded_ = true;
}

void ControlCycle::start(drivers::ActuatorSet& io, const trajectory::Program& program,
                         const trajectory::RebaseOptions& rebase) {
  drivers::ActuatorFeedback fb;
  model::JointVector q;
  model::Pose X;
  read_pose(io, fb, q, X);
  activate_owned(prepare_program(*model_, program, X, rebase), fb, q, X);
}

void ControlCycle::start_streaming(drivers::ActuatorSet& io,
                                   const trajectory::StreamingLimits& limits,
                                   const trajectory::Workspace& workspace) {
  drivers::ActuatorFeedback fb;
  model::JointVector q;
  model::Pose X;
  read_pose(io, fb, q, X);
  activate_owned(prepare_stream(*model_, limits, workspace, config_.period, X), fb, q, X);
}

trajectory::TargetStatus ControlCycle::stream_setpoint(const model::Pose& X) noexcept {
  if (!active_ || active_->kind != ReferenceKind::kStream || phase_ == CyclePhase::kStopped)
    return trajectory::TargetStatus::kNotActive;
  const trajectory::TargetStatus s = active_->stream->set_target(X);
  if (s == trajectory::TargetStatus::kAccepted) stream_fresh_ = true;
  return s;
}

void ControlCycle::end_stream() noexcept {
  if (active_ && active_->kind == ReferenceKind::kStream) active_->stream->hold();
}

bool ControlCycle::seed(const model::JointVector& q) noexcept {
  for (int i = 0; i < model_->n; ++i)
    if (!std::isfinite(q[i])) return false;
  model::Pose X;
  const model::FkResult fk = model::forward_kinematics(*model_, seed_data_, q, model_->home, X);
  if (fk.status != model::Status::kOk) return false;
  estimator_.reset(q, X);
  return true;
}

CycleStatus ControlCycle::step(drivers::ActuatorSet& io, CycleRecord& rec) noexcept {
  const int n = model_->n;
  rec.cycle = cycle_++;
  rec.status = CycleStatus::kOk;
  rec.command.n = n;
  rec.command.torque.fill(0.0);
  rec.command.request = drivers::DriveRequest::kHold;

  const drivers::IoStatus io_status = io.read(rec.feedback);
  std::uint32_t fresh = 0;  // joints whose position is new this cycle (the estimator's input)
  for (int i = 0; i < n; ++i) {
    q_meas_[i] = rec.feedback.drive[i].position;
    if (rec.feedback.drive[i].fresh) fresh |= 1U << i;
  }
  if (io_status == drivers::IoStatus::kBusError) rec.status = CycleStatus::kIoError;
  // The first cycles after start-up find the pose from home (the estimator tracks it after).
  if (!seeded_ && io_status != drivers::IoStatus::kNotReady) seeded_ = seed(q_meas_);
  if ((!seeded_ || estimator_.update(q_meas_, fresh) != EstimateStatus::kOk) &&
      rec.status == CycleStatus::kOk)
    rec.status = CycleStatus::kEstimateFailed;
  rec.est = estimator_.estimate();
  if (!seeded_) rec.est.status = EstimateStatus::kFkFailed;

  if (!active_) {  // idle: watch and write 0 N m, disable voltage (the filter's kDisabled)
    rec.phase = CyclePhase::kIdle;
    rec.t = 0.0;
    rec.ref.segment = 0;
    rec.ref.cartesian = trajectory::CartesianSample{};
    rec.ref.cartesian.X = rec.est.X;
    rec.ref.phase = trajectory::PhaseSample{};
    rec.control.tau.setZero(n);
    rec.control.tau_internal.setZero(n);
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
      if (static_cast<double>(enabling_cycles_) * config_.period > config_.enable_timeout)
        rec.status = CycleStatus::kEnableTimeout;
    }
  }

  rec.phase = phase_;
  rec.t = t_;
  const bool moving = phase_ == CyclePhase::kRunning || phase_ == CyclePhase::kHolding;
  trajectory::StreamingReference* stream = active_->stream ? &*active_->stream : nullptr;
  const trajectory::SampleStatus ss =
      stream ? stream->step(moving, rec.ref) : active_->sequencer->sample(t_, rec.ref);
  if (stream && phase_ == CyclePhase::kRunning && !stream->active()) phase_ = CyclePhase::kHolding;
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
      active_ != nullptr && (phase_ == CyclePhase::kRunning || phase_ == CyclePhase::kHolding);
  in.X_d = rec.ref.cartesian.X;
  in.deadline_missed = deadline_missed_;
  in.consecutive_deadline_misses = consecutive_misses_;
  // The watchdog runs while a stream is followed (not while the drives enable: the sender
  // cannot know when that ends); end_stream() turns it off.
  in.streaming = streaming_ || (active_ && active_->kind == ReferenceKind::kStream &&
                                active_->stream->active() && phase_ == CyclePhase::kRunning);
  in.stream_fresh = stream_fresh_;
  stream_fresh_ = false;
  const safety::SafetyState st = safety_.update(rec.feedback, in, rec.command);
  // A reference ends in kStopped when the filter stops; idle, only a stop (SS1 / STO) is a
  // safety stop: kDisabled is idle's normal state.
  const bool stopping = st == safety::SafetyState::kSs1 || st == safety::SafetyState::kSto;
  if (active_ && st != safety::SafetyState::kOperational) phase_ = CyclePhase::kStopped;
  if (active_ || stopping) {
    rec.phase = phase_;
    if (rec.status == CycleStatus::kOk &&
        (active_ ? st != safety::SafetyState::kOperational : stopping))
      rec.status = CycleStatus::kSafetyStop;
  }
  rec.safety = safety_.report();
  guard_.write(io, rec.command);
  return rec.status;
}

}  // namespace dualv::control
