#include "drivers/cia402_drive.hpp"

#include "drivers/canopen/clock.hpp"

namespace dualv::drivers {

using fw::Cia402State;

const char* to_string(StopCause c) noexcept {
  switch (c) {
    case StopCause::kNone:
      return "none";
    case StopCause::kFault:
      return "fault";
    case StopCause::kQuickStop:
      return "quick stop by the drive";
    case StopCause::kDisabled:
      return "disabled by the drive";
    case StopCause::kLost:
      return "drive lost";
  }
  return "?";
}

namespace {
constexpr Cia402State goal_state(Cia402Goal g) noexcept {
  switch (g) {
    case Cia402Goal::kOperationEnabled:
      return Cia402State::kOperationEnabled;
    case Cia402Goal::kQuickStopActive:
      return Cia402State::kQuickStopActive;
    default:
      return Cia402State::kSwitchOnDisabled;
  }
}
constexpr bool is_fault(Cia402State s) noexcept {
  return s == Cia402State::kFault || s == Cia402State::kFaultReactionActive;
}
constexpr std::uint16_t without_reset_bit(std::uint16_t cw) noexcept {
  return static_cast<std::uint16_t>(cw & ~fw::cw::kFaultReset);
}
}  // namespace

void Cia402Drive::own_stop(StopCause c) noexcept {
  own_stop_ = c;
  ++own_stops_;
  goal_ = Cia402Goal::kNone;  // latched: never back to Operation enabled by itself
  // Held disabled until asked again (from Quick stop active this is transition 12).
  controlword_ = fw::apply(fw::Command::kDisableVoltage, 0);
}

void Cia402Drive::on_statusword(std::uint16_t sw, std::uint64_t now_ns) noexcept {
  const fw::Result<fw::Statusword> d = fw::decode_statusword(sw);
  if (!d) {
    ++bad_statuswords_;
    return;
  }
  const Cia402State s = d->state;
  const bool changed = !known_ || s != state_;
  const Cia402State before = state_;
  const bool was_known = known_;
  statusword_ = sw;
  state_ = s;
  known_ = true;
  if (!changed) return;
  state_since_ns_ = now_ns;  // progress: the per-transition timer restarts
  if (!was_known) return;
  if (is_fault(s) && !is_fault(before)) {
    own_stop(StopCause::kFault);
  } else if (s == Cia402State::kQuickStopActive && goal_ != Cia402Goal::kQuickStopActive) {
    own_stop(StopCause::kQuickStop);
  } else if (before == Cia402State::kOperationEnabled && goal_ == Cia402Goal::kOperationEnabled &&
             s != Cia402State::kOperationEnabled) {
    own_stop(StopCause::kDisabled);
  }
}

void Cia402Drive::on_lost() noexcept {
  if (known_ && goal_ == Cia402Goal::kOperationEnabled) own_stop(StopCause::kLost);
  known_ = false;
  goal_ = Cia402Goal::kNone;
  reset_phase_ = ResetPhase::kIdle;
  controlword_ = fw::apply(fw::Command::kDisableVoltage, 0);
}

void Cia402Drive::time_out() noexcept {
  timed_out_ = true;
  ++transition_timeouts_;
  goal_ = Cia402Goal::kNone;
  reset_phase_ = ResetPhase::kIdle;
  controlword_ = fw::apply(fw::Command::kDisableVoltage, 0);
}

Cia402Output Cia402Drive::update(DriveRequest request, std::uint64_t now_ns) noexcept {
  // 1. The request changes the goal. kEnable and kFaultReset act on their leading edge (a
  // request held for many cycles acts once: after an own stop or a timeout the drive is not
  // re-enabled until the request is given again); kDisable and kQuickStop act every cycle.
  const bool edge = request != last_request_;
  last_request_ = request;
  if (edge && request != DriveRequest::kHold) timed_out_ = false;
  switch (request) {
    case DriveRequest::kHold:
      break;
    case DriveRequest::kEnable:
      // In Fault only kFaultReset acts; elsewhere walk to Operation enabled.
      if (edge && !(known_ && is_fault(state_)) && reset_phase_ == ResetPhase::kIdle &&
          goal_ != Cia402Goal::kOperationEnabled) {
        goal_ = Cia402Goal::kOperationEnabled;
        own_stop_ = StopCause::kNone;
        state_since_ns_ = now_ns;
      }
      break;
    case DriveRequest::kDisable:
      if (goal_ != Cia402Goal::kSwitchOnDisabled || reset_phase_ != ResetPhase::kIdle)
        state_since_ns_ = now_ns;
      goal_ = Cia402Goal::kSwitchOnDisabled;
      reset_phase_ = ResetPhase::kIdle;
      break;
    case DriveRequest::kQuickStop:
      if (goal_ == Cia402Goal::kOperationEnabled || goal_ == Cia402Goal::kNone)
        state_since_ns_ = now_ns;
      goal_ = (known_ && (state_ == Cia402State::kOperationEnabled ||
                          state_ == Cia402State::kQuickStopActive))
                  ? Cia402Goal::kQuickStopActive
                  : Cia402Goal::kSwitchOnDisabled;
      break;
    case DriveRequest::kFaultReset:
      // A new request restarts a reset still in progress (bit 7 low, then high again): a
      // drive that refused the first edge while its fault's cause remained sees a new one.
      if (edge && known_ && state_ == Cia402State::kFault) {
        reset_phase_ = ResetPhase::kLow;
        goal_ = Cia402Goal::kSwitchOnDisabled;
        state_since_ns_ = now_ns;
      }
      break;
  }

  // 2. The controlword.
  last_transition_ = 0;
  if (!known_) {
    controlword_ = fw::apply(fw::Command::kDisableVoltage, without_reset_bit(controlword_));
    return {controlword_, false};
  }
  if (reset_phase_ != ResetPhase::kIdle) {
    if (state_ != Cia402State::kFault) {
      reset_phase_ = ResetPhase::kIdle;  // done: the drive left Fault
    } else if (reset_phase_ == ResetPhase::kLow) {
      // Bit 7 low for one cycle so that the next one is a rising edge (transition 15).
      controlword_ = fw::apply(fw::Command::kDisableVoltage, without_reset_bit(controlword_));
      reset_phase_ = ResetPhase::kHigh;
      return {controlword_, false};
    } else {
      if ((controlword_ & fw::cw::kFaultReset) == 0) {
        ++fault_resets_;
        state_since_ns_ = now_ns;  // transition 15 is timed from the rising edge
      } else if (canopen::expired(state_since_ns_, now_ns, timeout_ns_)) {
        time_out();
        return {controlword_, false};
      }
      controlword_ = fw::apply(fw::Command::kFaultReset, controlword_);
      last_transition_ = 15;
      return {controlword_, false};
    }
  }
  controlword_ = without_reset_bit(controlword_);
  if (is_fault(state_)) {
    // A fault is left only through kFaultReset; until then, voltage off.
    goal_ = Cia402Goal::kNone;
    controlword_ = fw::apply(fw::Command::kDisableVoltage, controlword_);
    return {controlword_, false};
  }
  if (goal_ != Cia402Goal::kNone) {
    const Cia402State target = goal_state(goal_);
    const std::optional<fw::Transition> t = fw::next_transition(state_, target);
    const bool drive_moves_alone = state_ == Cia402State::kNotReadyToSwitchOn;
    if (t && t->command) {
      controlword_ = fw::apply(*t->command, controlword_);
      last_transition_ = t->number;
    } else if (state_ == target) {
      // Arrived (or found there): keep commanding the state, whatever we sent before.
      controlword_ =
          fw::apply(goal_ == Cia402Goal::kOperationEnabled  ? fw::Command::kEnableOperation
                    : goal_ == Cia402Goal::kQuickStopActive ? fw::Command::kQuickStop
                                                            : fw::Command::kDisableVoltage,
                    controlword_);
    }
    if ((t || drive_moves_alone) && state_ != target) {
      if (canopen::expired(state_since_ns_, now_ns, timeout_ns_)) {
        time_out();
        return {controlword_, false};
      }
    }
  }
  const bool torque =
      state_ == Cia402State::kOperationEnabled && goal_ == Cia402Goal::kOperationEnabled;
  return {controlword_, torque};
}

DriveState Cia402Drive::drive_state() const noexcept {
  if (!known_) return DriveState::kOffline;
  switch (state_) {
    case Cia402State::kOperationEnabled:
      return DriveState::kEnabled;
    case Cia402State::kQuickStopActive:
      return DriveState::kQuickStop;
    case Cia402State::kFault:
    case Cia402State::kFaultReactionActive:
      return DriveState::kFault;
    default:
      return DriveState::kDisabled;
  }
}

}  // namespace dualv::drivers
