#include "sim/canopen/cia402_slave.hpp"

namespace dualv::sim::canopen {

using fw::Cia402State;

void Cia402Slave::go(Cia402State to, std::uint8_t transition) noexcept {
  state_ = to;
  last_transition_ = transition;
  if (to != Cia402State::kQuickStopActive) quick_stop_to_disabled_ = false;
}

void Cia402Slave::power_on() noexcept {
  previous_controlword_ = 0;
  go(Cia402State::kNotReadyToSwitchOn, 0);
  go(Cia402State::kSwitchOnDisabled, 1);
}

ControlwordEffect Cia402Slave::on_controlword(std::uint16_t cw, std::int16_t quick_stop_option,
                                              bool power_stage_blocked,
                                              bool fault_cause_remains) noexcept {
  const bool rising_reset =
      (cw & fw::cw::kFaultReset) != 0 && (previous_controlword_ & fw::cw::kFaultReset) == 0;
  previous_controlword_ = cw;
  switch (state_) {
    case Cia402State::kFault:
      if (!rising_reset) return ControlwordEffect::kNone;  // 15 on the 0 -> 1 edge only
      if (fault_cause_remains) return ControlwordEffect::kFaultResetRefused;
      go(Cia402State::kSwitchOnDisabled, 15);
      return ControlwordEffect::kFaultReset;
    case Cia402State::kNotReadyToSwitchOn:
    case Cia402State::kFaultReactionActive:
      return ControlwordEffect::kNone;  // the drive moves on its own
    default:
      break;
  }
  // 16 only where 605Ah keeps the drive in Quick stop active (5..8).
  const bool stays =
      quick_stop_option >= static_cast<std::int16_t>(fw::QuickStopOption::kSlowDownRampStay);
  const std::optional<fw::Transition> t =
      fw::slave_transition(state_, fw::decode_command(cw), stays);
  if (!t) return ControlwordEffect::kNone;
  if (t->number == 2 && power_stage_blocked) return ControlwordEffect::kNone;
  if (t->number == 11)
    quick_stop(quick_stop_option);
  else
    go(t->to, t->number);
  return ControlwordEffect::kTransition;
}

void Cia402Slave::quick_stop(std::int16_t option) noexcept {
  go(Cia402State::kQuickStopActive, 11);
  if (option == static_cast<std::int16_t>(fw::QuickStopOption::kDisableDrive))
    go(Cia402State::kSwitchOnDisabled, 12);
  else if (option <= static_cast<std::int16_t>(fw::QuickStopOption::kVoltageLimit))
    quick_stop_to_disabled_ = true;  // "stopped" at the next SYNC (the ramp is not modelled)
}

bool Cia402Slave::disable_voltage() noexcept {
  switch (state_) {
    case Cia402State::kReadyToSwitchOn:
      go(Cia402State::kSwitchOnDisabled, 7);
      return true;
    case Cia402State::kSwitchedOn:
      go(Cia402State::kSwitchOnDisabled, 10);
      return true;
    case Cia402State::kOperationEnabled:
      go(Cia402State::kSwitchOnDisabled, 9);
      return true;
    case Cia402State::kQuickStopActive:
      go(Cia402State::kSwitchOnDisabled, 12);
      return true;
    default:
      return false;
  }
}

bool Cia402Slave::fault() noexcept {
  if (state_ == Cia402State::kFault) return false;
  go(Cia402State::kFaultReactionActive, 13);
  go(Cia402State::kFault, 14);  // no reaction ramp modelled
  return true;
}

void Cia402Slave::on_sync() noexcept {
  if (state_ == Cia402State::kQuickStopActive && quick_stop_to_disabled_)
    go(Cia402State::kSwitchOnDisabled, 12);  // the quick stop has "stopped"
}

std::uint16_t Cia402Slave::statusword(std::uint16_t extra) const noexcept {
  auto w = static_cast<std::uint16_t>(fw::statusword_bits(state_) | fw::sw::kRemote | extra);
  if (state_ == Cia402State::kSwitchedOn || state_ == Cia402State::kOperationEnabled ||
      state_ == Cia402State::kQuickStopActive)
    w |= fw::sw::kVoltageEnabled;
  return w;
}

}  // namespace dualv::sim::canopen
