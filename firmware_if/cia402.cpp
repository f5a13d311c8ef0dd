#include "firmware_if/cia402.hpp"

#include <array>

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

constexpr int index_of(S s) noexcept { return static_cast<int>(s); }
constexpr int kStates = 8;

// Transition number for one step from `from` towards `target`; 0 = none: the first step of
// a shortest path through the host-commanded transitions of kTransitions (breadth first,
// in table order), 15 from Fault, 16 deliberately unused (see the header).
std::uint8_t step(S from, S target) noexcept {
  if (from == target) return 0;
  if (from == S::kFault) return 15;
  // Quick stop active is a target only from Operation enabled (11): a drive not enabled is
  // never enabled just to be quick-stopped.
  if (target == S::kQuickStopActive && from != S::kOperationEnabled) return 0;
  // Breadth first from `target` backwards: dist[s] = commanded steps from s to target.
  std::array<int, 16> dist{};
  dist.fill(-1);
  dist[static_cast<std::size_t>(index_of(target))] = 0;
  for (int d = 0; d < kStates; ++d)
    for (const Transition& t : kTransitions) {
      if (!t.command || t.number == 15 || t.number == 16) continue;
      if (dist[static_cast<std::size_t>(index_of(t.to))] == d &&
          dist[static_cast<std::size_t>(index_of(t.from))] < 0)
        dist[static_cast<std::size_t>(index_of(t.from))] = d + 1;
    }
  const int here = dist[static_cast<std::size_t>(index_of(from))];
  if (here <= 0) return 0;
  for (const Transition& t : kTransitions) {
    if (!t.command || t.number == 15 || t.number == 16 || t.from != from) continue;
    if (dist[static_cast<std::size_t>(index_of(t.to))] == here - 1) return t.number;
  }
  return 0;
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
