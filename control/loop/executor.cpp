#include "control/loop/executor.hpp"

#include <cmath>
#include <stdexcept>

namespace dualv::control {

const char* to_string(LoopMode m) noexcept {
  switch (m) {
    case LoopMode::kIdle:
      return "idle";
    case LoopMode::kProgram:
      return "program";
    case LoopMode::kStream:
      return "stream";
    case LoopMode::kHold:
      return "hold";
    case LoopMode::kSafeStop:
      return "safe stop";
  }
  return "unknown";
}

const char* to_string(IdleMode m) noexcept { return m == IdleMode::kHold ? "hold" : "disabled"; }

const char* to_string(RefuseReason r) noexcept {
  switch (r) {
    case RefuseReason::kNone:
      return "none";
    case RefuseReason::kEstop:
      return "an e-stop came while it was prepared";
    case RefuseReason::kLatched:
      return "a stop is latched: reset it first";
    case RefuseReason::kBusy:
      return "a program or stream is running";
    case RefuseReason::kMoved:
      return "the robot moved since the start was prepared";
    case RefuseReason::kNoPose:
      return "the loop has no valid pose (forward kinematics)";
    case RefuseReason::kShuttingDown:
      return "the loop is shutting down";
    case RefuseReason::kInvalid:
      return "invalid reference or feedback";
  }
  return "unknown";
}

Executor::Executor(const model::Model& model, const ControlSetup& setup,
                   const ExecutorConfig& config, drivers::ActuatorSet& io)
    : model_(&model),
      config_(config),
      io_(&io),
      cycle_(model, setup, config.cycle),
      hold_(control::prepare_stream(model, {}, {}, config.cycle.period, model.home)) {
  if (io.size() != model.n)
    throw std::runtime_error("the actuator set has " + std::to_string(io.size()) +
                             " drives but the model has " + std::to_string(model.n) + " chains");
  hold_->kind = ReferenceKind::kHold;
  hold_->name = "hold";
}

Executor::~Executor() {
  collect();
  LoopCommand c;
  while (commands_.try_pop(c)) delete c.reference;
}

std::uint64_t Executor::current_epoch() const noexcept {
  return own_estops_.load(std::memory_order_acquire) +
         (watched_ ? watched_->load(std::memory_order_acquire) : 0);
}

std::uint64_t Executor::estop_epoch() const noexcept { return current_epoch(); }

void Executor::request_estop(safety::StopSource source) noexcept {
  own_estops_.fetch_add(1, std::memory_order_acq_rel);
  cycle_.safety().request_stop(source);
}

std::unique_ptr<PreparedReference> Executor::prepare_program(
    const trajectory::Program& program, const trajectory::RebaseOptions& rebase,
    std::uint64_t epoch) {
  const LoopSnapshot s = snapshot();
  if (s.cycle < 0 || !s.pose_valid)
    throw std::runtime_error("the control loop reports no valid pose yet (forward kinematics)");
  auto ref = control::prepare_program(*model_, program, s.pose(), rebase);
  ref->estop_epoch = epoch;
  return ref;
}

std::unique_ptr<PreparedReference> Executor::prepare_stream(
    const trajectory::StreamingLimits& limits, const trajectory::Workspace& workspace,
    std::uint64_t epoch) {
  const LoopSnapshot s = snapshot();
  if (s.cycle < 0 || !s.pose_valid)
    throw std::runtime_error("the control loop reports no valid pose yet (forward kinematics)");
  auto ref = control::prepare_stream(*model_, limits, workspace, config_.cycle.period, s.pose());
  ref->estop_epoch = epoch;
  return ref;
}

std::uint64_t Executor::start(std::unique_ptr<PreparedReference> reference) {
  const std::uint64_t id = next_id_++;
  reference->id = id;
  LoopCommand c;
  c.kind = LoopCommand::Kind::kStart;
  c.reference = reference.get();
  if (!commands_.try_push(c)) return 0;  // the unique_ptr frees it
  reference.release();                   // the loop owns it now; retired through retired_
  return id;
}

bool Executor::submit(LoopCommand::Kind kind) noexcept {
  LoopCommand c;
  c.kind = kind;
  return kind != LoopCommand::Kind::kStart && commands_.try_push(c);
}

void Executor::collect() {
  PreparedReference* r = nullptr;
  while (retired_.try_pop(r)) delete r;
}

void Executor::emit(LoopEvent::Kind kind, std::uint64_t id, RefuseReason reason) noexcept {
  LoopEvent e;
  e.kind = kind;
  e.id = id;
  e.cycle = rec_.cycle;
  e.t = rec_.t;
  e.reason = reason;
  e.status = rec_.status;
  e.latched = cycle_.safety().report().latched;
  events_.try_push(e);  // counted when full (events_dropped)
}

void Executor::retire(PreparedReference* ref) noexcept {
  if (ref == nullptr || ref == hold_.get()) return;
  // Freed by the supervisor (collect); a full queue leaks rather than free on this thread.
  retired_.try_push(ref);
}

void Executor::take_start(PreparedReference* ref) noexcept {
  const safety::SafetyFilter& f = cycle_.safety();
  const model::Pose X = rec_.est.X;
  RefuseReason why = RefuseReason::kNone;
  if (shutting_down_)
    why = RefuseReason::kShuttingDown;
  else if (current_epoch() != ref->estop_epoch)
    why = RefuseReason::kEstop;
  else if (mode_ == LoopMode::kProgram || mode_ == LoopMode::kStream)
    why = RefuseReason::kBusy;
  else if (f.report().latched != 0 || mode_ == LoopMode::kSafeStop)
    why = RefuseReason::kLatched;
  else if (!cycle_.pose_known() || rec_.est.status != EstimateStatus::kOk || !X.allFinite())
    why = RefuseReason::kNoPose;
  else if ((ref->kind == ReferenceKind::kProgram && !ref->sequencer) ||
           (ref->kind == ReferenceKind::kStream && !ref->stream) ||
           ref->kind == ReferenceKind::kHold)
    why = RefuseReason::kInvalid;
  else if (std::hypot(X.x() - ref->start.x(), X.y() - ref->start.y()) > config_.takeover_position ||
           std::abs(X.z() - ref->start.z()) > config_.takeover_angle)
    why = RefuseReason::kMoved;
  if (why == RefuseReason::kNone) {
    const safety::ArmStatus a = cycle_.activate(*ref, rec_.feedback);
    if (a == safety::ArmStatus::kLatched) why = RefuseReason::kLatched;
    if (a == safety::ArmStatus::kInvalidFeedback) why = RefuseReason::kInvalid;
  }
  if (why != RefuseReason::kNone) {
    emit(LoopEvent::Kind::kRefused, ref->id, why);
    retire(ref);
    return;
  }
  mode_ = ref->kind == ReferenceKind::kProgram ? LoopMode::kProgram : LoopMode::kStream;
  settle_cycles_ = 0;
  emit(LoopEvent::Kind::kStarted, ref->id);
}

void Executor::take_commands() noexcept {
  LoopCommand c;
  while (commands_.try_pop(c)) {
    switch (c.kind) {
      case LoopCommand::Kind::kStart:
        take_start(c.reference);
        break;
      case LoopCommand::Kind::kStop:
        // A program stops under control (SS1); a stream ends normally; a hold lets go.
        if (mode_ == LoopMode::kProgram)
          cycle_.safety().request_stop(safety::StopSource::kCli);
        else if (mode_ == LoopMode::kStream)
          cycle_.end_stream();
        else if (mode_ == LoopMode::kHold)
          end_reference(false);
        break;
      case LoopCommand::Kind::kEndStream:
        if (mode_ == LoopMode::kStream) cycle_.end_stream();
        break;
      case LoopCommand::Kind::kReset:
        cycle_.safety().request_reset();
        reset_waiting_ = true;
        break;
      case LoopCommand::Kind::kShutdown:
        shutting_down_ = true;
        if (mode_ == LoopMode::kProgram || mode_ == LoopMode::kStream)
          cycle_.safety().request_stop(safety::StopSource::kCli);
        else if (mode_ == LoopMode::kHold)
          end_reference(false);
        break;
    }
  }
}

// The reference followed ends normally: hold its last pose (loop.idle: hold) or go idle.
void Executor::end_reference(bool finished) noexcept {
  PreparedReference* ref = cycle_.active();
  if (ref == nullptr) return;
  if (finished) emit(LoopEvent::Kind::kFinished, ref->id);
  if (finished && config_.idle == IdleMode::kHold && !shutting_down_ &&
      cycle_.safety().state() == safety::SafetyState::kOperational) {
    hold_->projection = ref->projection;
    hold_->feedforward = ref->feedforward;
    hold_->stream->reset(rec_.ref.cartesian.X);
    hold_->stream->hold();
    hold_->id = ref->id;
    cycle_.activate(*hold_, rec_.feedback);  // operational: no re-arm, no enable phase
    mode_ = LoopMode::kHold;
  } else {
    cycle_.deactivate();
    mode_ = LoopMode::kIdle;
  }
  retire(ref);
}

void Executor::after_step() noexcept {
  const safety::SafetyState st = cycle_.safety().state();
  const bool stop = st == safety::SafetyState::kSs1 || st == safety::SafetyState::kSto;
  PreparedReference* active = cycle_.active();
  if (active &&
      (cycle_.phase() == CyclePhase::kStopped || rec_.status == CycleStatus::kEnableTimeout)) {
    // The safety filter stopped the reference (or its drives never enabled): it is abandoned;
    // the filter carries the stop out (SS1 brakes without a reference).
    emit(LoopEvent::Kind::kStopped, active->id);
    cycle_.deactivate();
    retire(active);
    mode_ = stop ? LoopMode::kSafeStop : LoopMode::kIdle;
  } else if (!active && stop && mode_ != LoopMode::kSafeStop) {
    emit(LoopEvent::Kind::kStopped, 0);  // a stop while idle (e-stop, a drive fault ...)
    mode_ = LoopMode::kSafeStop;
  }
  if (mode_ == LoopMode::kSafeStop) {
    if (st == safety::SafetyState::kSto && !torque_off_reported_) {
      emit(LoopEvent::Kind::kTorqueOff, 0);
      torque_off_reported_ = true;
    } else if (st == safety::SafetyState::kDisabled) {  // a reset was accepted
      emit(LoopEvent::Kind::kReset, 0);
      mode_ = LoopMode::kIdle;
      torque_off_reported_ = false;
      reset_waiting_ = false;
    }
  }
  // A reset the filter is done with and that did not lead to idle was refused (its causes
  // are still active, or the stop is still braking); one with nothing latched changes nothing.
  if (reset_waiting_ && !cycle_.safety().report().reset_pending) {
    reset_waiting_ = false;
    if (mode_ == LoopMode::kSafeStop) emit(LoopEvent::Kind::kResetRefused, 0);
  }
  if (active && (mode_ == LoopMode::kProgram || mode_ == LoopMode::kStream) &&
      cycle_.phase() == CyclePhase::kHolding &&
      static_cast<double>(++settle_cycles_) * config_.cycle.period >= active->settle_time - 1e-12)
    end_reference(true);
}

CycleResult Executor::step(const CycleInfo& info) noexcept {
  // 1. E-stops latch in every mode; the watched counter's increments since start-up included.
  if (watched_) {
    const std::uint64_t w = watched_->load(std::memory_order_acquire);
    if (w != watched_seen_) {
      watched_seen_ = w;
      cycle_.safety().request_stop(safety::StopSource::kLcm);
    }
  }
  // 2. Commands, at the cycle boundary; then the hooks see the mode this cycle runs in.
  take_commands();
  cycle_reference_ = cycle_.active() ? cycle_.active()->id : 0;
  if (hooks_) hooks_->before_cycle(*this, info);
  // 3. The cycle: read -> estimate -> reference -> control law -> safety -> write.
  if (injected_misses_ > 0)
    cycle_.note_timing(true, injected_misses_);
  else
    cycle_.note_timing(info.skipped_releases > 0, info.consecutive_misses);
  cycle_.step(*io_, rec_);
  after_step();
  if (hooks_) hooks_->after_cycle(*this, rec_, info);

  LoopSnapshot s;
  s.cycle = rec_.cycle;
  s.mode = mode_;
  s.phase = cycle_.phase();
  s.safety = cycle_.safety().state();
  s.latched = cycle_.safety().report().latched;
  s.pose_valid = cycle_.pose_known() && rec_.est.status == EstimateStatus::kOk;
  for (int k = 0; k < 3; ++k) s.X[k] = rec_.est.X[k];
  s.t = rec_.t;
  s.duration = cycle_.program_duration();
  s.reference = reference_id();
  s.estops_seen = current_epoch();
  if (const trajectory::StreamingReference* ref = cycle_.stream();
      ref && mode_ == LoopMode::kStream) {
    stream_accepted_ = ref->accepted();
    stream_refused_ = ref->refused();
  }
  s.stream_accepted = stream_accepted_;
  s.stream_refused = stream_refused_;
  snapshot_.write(s);

  // 4. Shutdown: once nothing is followed and the torque is off.
  if (shutting_down_ &&
      (mode_ == LoopMode::kIdle ||
       (mode_ == LoopMode::kSafeStop && cycle_.safety().state() == safety::SafetyState::kSto))) {
    emit(LoopEvent::Kind::kLoopEnded, 0);
    return CycleResult::kStop;
  }
  return CycleResult::kContinue;
}

}  // namespace dualv::control
