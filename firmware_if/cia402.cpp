#include "firmware_if/cia402.hpp"

namespace dualv::fw {

const char* to_string(Cia402State s) noexcept {
  switch (s) {
    case Cia402State::kNotReadyToSwitchOn:
      return "Not ready to switch on";
    case Cia402State::kSwitchOnDisabled:
      return "Switch on disabled";
    case Cia402State::kReadyToSwitchOn:
      return "Ready to switch on";
    case Cia402State::kSwitchedOn:
      return "Switched on";
    case Cia402State::kOperationEnabled:
      return "Operation enabled";
    case Cia402State::kQuickStopActive:
      return "Quick stop active";
    case Cia402State::kFaultReactionActive:
      return "Fault reaction active";
    case Cia402State::kFault:
      return "Fault";
  }
  return "?";
}

const char* to_string(Command c) noexcept {
  switch (c) {
    case Command::kShutdown:
      return "shutdown";
    case Command::kSwitchOn:
      return "switch on";
    case Command::kDisableVoltage:
      return "disable voltage";
    case Command::kQuickStop:
      return "quick stop";
    case Command::kDisableOperation:
      return "disable operation";
    case Command::kEnableOperation:
      return "enable operation";
    case Command::kFaultReset:
      return "fault reset";
  }
  return "?";
}

namespace {

using S = Cia402State;

// Transition number for one step from `from` towards `target`; 0 = none. Shortest paths
// through host-commanded transitions (figure 22), 16 deliberately unused (see header).
constexpr std::uint8_t step(S from, S target) noexcept {
  if (from == target) return 0;
  switch (from) {
    case S::kNotReadyToSwitchOn:
    case S::kFaultReactionActive:
      return 0;  // the drive moves on its own (1, 14)
    case S::kFault:
      return 15;
    default:
      break;
  }
  switch (target) {
    case S::kSwitchOnDisabled:
      switch (from) {
        case S::kReadyToSwitchOn:
          return 7;
        case S::kSwitchedOn:
          return 10;
        case S::kOperationEnabled:
          return 9;
        case S::kQuickStopActive:
          return 12;
        default:
          return 0;
      }
    case S::kReadyToSwitchOn:
      switch (from) {
        case S::kSwitchOnDisabled:
          return 2;
        case S::kSwitchedOn:
          return 6;
        case S::kOperationEnabled:
          return 8;
        case S::kQuickStopActive:
          return 12;
        default:
          return 0;
      }
    case S::kSwitchedOn:
      switch (from) {
        case S::kSwitchOnDisabled:
          return 2;
        case S::kReadyToSwitchOn:
          return 3;
        case S::kOperationEnabled:
          return 5;
        case S::kQuickStopActive:
          return 12;
        default:
          return 0;
      }
    case S::kOperationEnabled:
      switch (from) {
        case S::kSwitchOnDisabled:
          return 2;
        case S::kReadyToSwitchOn:
          return 3;
        case S::kSwitchedOn:
          return 4;
        case S::kQuickStopActive:
          return 12;
        default:
          return 0;
      }
    case S::kQuickStopActive:
      return from == S::kOperationEnabled ? 11 : 0;
    default:
      return 0;  // Not ready, Fault reaction active, Fault: not commandable targets
  }
}

}  // namespace

std::optional<Transition> next_transition(Cia402State from, Cia402State target) noexcept {
  // Fault reset only makes sense towards a state the host can command.
  if (from == S::kFault && (target == S::kFault || target == S::kFaultReactionActive ||
                            target == S::kNotReadyToSwitchOn || target == S::kQuickStopActive))
    return std::nullopt;
  const std::uint8_t n = step(from, target);
  if (n == 0) return std::nullopt;
  return find_transition(n);
}

}  // namespace dualv::fw
