#pragma once
// CiA 402-2 drive state machine (section 6.2, "PDS FSA"): controlword commands, statusword
// decoding, the transition table, modes of operation and option codes.
#include <array>
#include <cstdint>
#include <optional>

#include "firmware_if/result.hpp"

namespace dualv::fw {

// ---- controlword 6040h bits (CiA 402-2 6.2.1) ---------------------------------------
namespace cw {
inline constexpr std::uint16_t kSwitchOn = 1u << 0;
inline constexpr std::uint16_t kEnableVoltage = 1u << 1;
inline constexpr std::uint16_t kQuickStop = 1u << 2;  // active LOW: 0 requests quick stop
inline constexpr std::uint16_t kEnableOperation = 1u << 3;
inline constexpr std::uint16_t kFaultReset = 1u << 7;  // acts on the 0 -> 1 edge
inline constexpr std::uint16_t kHalt = 1u << 8;
// Bits the state machine commands use (0..3, 7); the rest are kept by apply().
inline constexpr std::uint16_t kStateMachineMask = 0x008F;
}  // namespace cw

// ---- statusword 6041h bits (CiA 402-2 6.2.2) ----------------------------------------
namespace sw {
inline constexpr std::uint16_t kReadyToSwitchOn = 1u << 0;
inline constexpr std::uint16_t kSwitchedOn = 1u << 1;
inline constexpr std::uint16_t kOperationEnabled = 1u << 2;
inline constexpr std::uint16_t kFault = 1u << 3;
inline constexpr std::uint16_t kVoltageEnabled = 1u << 4;
inline constexpr std::uint16_t kQuickStop = 1u << 5;  // 0 = quick stop active
inline constexpr std::uint16_t kSwitchOnDisabled = 1u << 6;
inline constexpr std::uint16_t kWarning = 1u << 7;
inline constexpr std::uint16_t kRemote = 1u << 9;
inline constexpr std::uint16_t kTargetReached = 1u << 10;
inline constexpr std::uint16_t kInternalLimitActive = 1u << 11;
// CST (mode 10): bit 12 = "target torque ignored" when 0 (drive does not follow).
inline constexpr std::uint16_t kDriveFollowsCommand = 1u << 12;
}  // namespace sw

enum class Cia402State : std::uint8_t {
  kNotReadyToSwitchOn,
  kSwitchOnDisabled,
  kReadyToSwitchOn,
  kSwitchedOn,
  kOperationEnabled,
  kQuickStopActive,
  kFaultReactionActive,
  kFault,
};
const char* to_string(Cia402State s) noexcept;

// Statusword patterns (CiA 402-2 table 30): state = (sw & mask) == value.
struct StatePattern {
  Cia402State state;
  std::uint16_t mask;
  std::uint16_t value;
};
inline constexpr std::array<StatePattern, 8> kStatePatterns{{
    {Cia402State::kNotReadyToSwitchOn, 0x004F, 0x0000},
    {Cia402State::kSwitchOnDisabled, 0x004F, 0x0040},
    {Cia402State::kReadyToSwitchOn, 0x006F, 0x0021},
    {Cia402State::kSwitchedOn, 0x006F, 0x0023},
    {Cia402State::kOperationEnabled, 0x006F, 0x0027},
    {Cia402State::kQuickStopActive, 0x006F, 0x0007},
    {Cia402State::kFaultReactionActive, 0x004F, 0x000F},
    {Cia402State::kFault, 0x004F, 0x0008},
}};

struct Statusword {
  Cia402State state = Cia402State::kNotReadyToSwitchOn;
  bool voltage_enabled = false;
  bool warning = false;
  bool remote = false;  // controlword is obeyed (CAN in charge)
  bool target_reached = false;
  bool internal_limit_active = false;
  bool drive_follows_command = false;  // CST bit 12
  friend constexpr bool operator==(const Statusword&, const Statusword&) = default;
};

// kBadValue when bits 0..3, 5, 6 match no state of table 30.
constexpr Result<Statusword> decode_statusword(std::uint16_t s) noexcept {
  for (const StatePattern& p : kStatePatterns) {
    if ((s & p.mask) == p.value) {
      return Statusword{p.state,
                        (s & sw::kVoltageEnabled) != 0,
                        (s & sw::kWarning) != 0,
                        (s & sw::kRemote) != 0,
                        (s & sw::kTargetReached) != 0,
                        (s & sw::kInternalLimitActive) != 0,
                        (s & sw::kDriveFollowsCommand) != 0};
    }
  }
  return Error::kBadValue;
}
// A statusword the drive (emulator) reports in `state`: the state's pattern, nothing else.
constexpr std::uint16_t statusword_bits(Cia402State s) noexcept {
  for (const StatePattern& p : kStatePatterns)
    if (p.state == s) return p.value;
  return 0;
}

// ---- commands (CiA 402-2 table 29) ------------------------------------------------------
enum class Command : std::uint8_t {
  kShutdown,          // transitions 2, 6, 8
  kSwitchOn,          // 3
  kDisableVoltage,    // 7, 9, 10, 12
  kQuickStop,         // 7, 10, 11
  kDisableOperation,  // 5
  kEnableOperation,   // 4, 16
  kFaultReset,        // 15 (rising edge of bit 7)
};
const char* to_string(Command c) noexcept;

struct CommandBits {
  std::uint16_t set;
  std::uint16_t reset;
};
constexpr CommandBits command_bits(Command c) noexcept {
  switch (c) {
    case Command::kShutdown:
      return {0x0006, 0x0081};  // 0xxx x110
    case Command::kSwitchOn:
      return {0x0007, 0x0088};  // 0xxx 0111
    case Command::kDisableVoltage:
      return {0x0000, 0x0082};  // 0xxx xx0x
    case Command::kQuickStop:
      return {0x0002, 0x0084};  // 0xxx x01x
    case Command::kDisableOperation:
      return {0x0007, 0x0088};  // 0xxx 0111
    case Command::kEnableOperation:
      return {0x000F, 0x0080};  // 0xxx 1111
    case Command::kFaultReset:
      return {0x0080, 0x0000};  // 0 -> 1 on bit 7
  }
  return {0, 0};
}
// The controlword carrying `c`: the command's defined bits set/reset, every other bit of
// `previous` kept (halt, mode-specific and manufacturer bits, and the command's own
// don't-care bits, e.g. bit 3 for shutdown).
constexpr std::uint16_t apply(Command c, std::uint16_t previous = 0) noexcept {
  const CommandBits b = command_bits(c);
  return static_cast<std::uint16_t>((previous & ~b.reset) | b.set);
}
// Which command a controlword expresses, as a drive reads it (table 29, bits 0..3). Every
// pattern of those bits is one command (kSwitchOn also stands for disable operation, same
// bits). Bit 7 (fault reset) acts on its rising edge only, which the drive tracks itself.
constexpr Command decode_command(std::uint16_t c) noexcept {
  if ((c & cw::kEnableVoltage) == 0) return Command::kDisableVoltage;  // xx0x
  if ((c & cw::kQuickStop) == 0) return Command::kQuickStop;           // x01x
  if ((c & cw::kSwitchOn) == 0) return Command::kShutdown;             // x110
  if ((c & cw::kEnableOperation) == 0) return Command::kSwitchOn;      // 0111
  return Command::kEnableOperation;                                    // 1111
}

// ---- transition table (CiA 402-2 figure 22 / table 28) ---------------------------------
struct Transition {
  std::uint8_t number;
  Cia402State from;
  Cia402State to;
  std::optional<Command> command;  // nullopt: the drive makes it on its own (0, 1, 13, 14)
};
// Transitions 0 (power on) and 13 (fault, from any state) have no single source state and
// are not listed; 1 and 14 are listed with no command: the drive makes them on its own.
inline constexpr std::array<Transition, 15> kTransitions{{
    {1, Cia402State::kNotReadyToSwitchOn, Cia402State::kSwitchOnDisabled, std::nullopt},
    {2, Cia402State::kSwitchOnDisabled, Cia402State::kReadyToSwitchOn, Command::kShutdown},
    {3, Cia402State::kReadyToSwitchOn, Cia402State::kSwitchedOn, Command::kSwitchOn},
    {4, Cia402State::kSwitchedOn, Cia402State::kOperationEnabled, Command::kEnableOperation},
    {5, Cia402State::kOperationEnabled, Cia402State::kSwitchedOn, Command::kDisableOperation},
    {6, Cia402State::kSwitchedOn, Cia402State::kReadyToSwitchOn, Command::kShutdown},
    {7, Cia402State::kReadyToSwitchOn, Cia402State::kSwitchOnDisabled, Command::kDisableVoltage},
    {8, Cia402State::kOperationEnabled, Cia402State::kReadyToSwitchOn, Command::kShutdown},
    {9, Cia402State::kOperationEnabled, Cia402State::kSwitchOnDisabled, Command::kDisableVoltage},
    {10, Cia402State::kSwitchedOn, Cia402State::kSwitchOnDisabled, Command::kDisableVoltage},
    {11, Cia402State::kOperationEnabled, Cia402State::kQuickStopActive, Command::kQuickStop},
    {12, Cia402State::kQuickStopActive, Cia402State::kSwitchOnDisabled, Command::kDisableVoltage},
    {14, Cia402State::kFaultReactionActive, Cia402State::kFault, std::nullopt},
    {15, Cia402State::kFault, Cia402State::kSwitchOnDisabled, Command::kFaultReset},
    {16, Cia402State::kQuickStopActive, Cia402State::kOperationEnabled, Command::kEnableOperation},
}};

constexpr std::optional<Transition> find_transition(std::uint8_t number) noexcept {
  for (const Transition& t : kTransitions)
    if (t.number == number) return t;
  return std::nullopt;
}

// kTransitions is the one owner of the state machine: the host side (next_transition, and
// through it drivers/cia402_drive.hpp) and the drive side (slave_transition: the CiA 402
// slave part sim/canopen/cia402_slave.cpp, which the drive emulator and the tests' fake
// slave are built from) are both derived from it.

// Whether a drive that reads command `c` in `t.from` takes `t` (CiA 402-2 table 29: quick
// stop also gives 7 and 10 outside Operation enabled; switch on and disable operation are
// the same bits, so kSwitchOn also gives 5).
constexpr bool takes(const Transition& t, Command c) noexcept {
  if (!t.command) return false;
  if (*t.command == c) return true;
  if (c == Command::kQuickStop && (t.number == 7 || t.number == 10)) return true;
  if (c == Command::kSwitchOn && *t.command == Command::kDisableOperation) return true;
  if (c == Command::kDisableOperation && *t.command == Command::kSwitchOn) return true;
  // Enable operation contains switch on's bits: from Ready to switch on it gives 3.
  return c == Command::kEnableOperation && t.number == 3;
}

// The drive side: the transition a drive in `from` makes when its controlword expresses `c`
// (decode_command). Transition 16 only when `quick_stop_stays` (605Ah 5..8: the drive stays
// in Quick stop active and may be re-enabled); 15 is not a command here (bit 7's rising
// edge, which the drive tracks). nullopt: the command changes nothing in that state.
constexpr std::optional<Transition> slave_transition(Cia402State from, Command c,
                                                     bool quick_stop_stays = false) noexcept {
  for (const Transition& t : kTransitions) {
    if (t.from != from || t.number == 15 || (t.number == 16 && !quick_stop_stays)) continue;
    if (takes(t, c)) return t;
  }
  return std::nullopt;
}

// The host side: the host-commanded transition that moves a drive in `from` one step
// towards `target`, the first step of a shortest path through kTransitions.
// nullopt when from == target, when only the drive can move (Not ready to switch on,
// Fault reaction active), or when `target` is not a state the host can command (Not ready,
// Fault reaction active, Fault; Quick stop active from anywhere but Operation enabled).
// From Quick stop active towards Operation enabled this takes 12 (disable voltage) and the
// full 2-3-4 path, never 16: re-enabling goes through Ready to switch on, so a stale target
// is never applied (docs/architecture.md users #1) and it works whatever 605Ah says.
// From Fault the command is fault reset (15) for targets Switch on disabled .. Operation
// enabled; the caller sends bit 7 = 0 first so that bit 7 rises.
std::optional<Transition> next_transition(Cia402State from, Cia402State target) noexcept;

// ---- modes of operation 6060h / 6061h (CiA 402-2 table 40) -----------------------------
enum class ModeOfOperation : std::int8_t {
  kNoMode = 0,
  kProfilePosition = 1,
  kVelocity = 2,
  kProfileVelocity = 3,
  kProfileTorque = 4,
  kHoming = 6,
  kInterpolatedPosition = 7,
  kCyclicSyncPosition = 8,
  kCyclicSyncVelocity = 9,
  kCyclicSyncTorque = 10,  // the contract's mode
};
// 6502h supported drive modes: bit (mode - 1) for modes 1..10.
constexpr std::uint32_t supported_mode_bit(ModeOfOperation m) noexcept {
  const auto v = static_cast<std::int8_t>(m);
  return (v >= 1 && v <= 10) ? (1u << (v - 1)) : 0u;
}

// ---- option codes ------------------------------------------------------------------------
// 6007h abort connection option (CiA 402-2): what the drive does when the host's heartbeat
// or an RPDO deadline is lost. Default configured: kQuickStop (docs/architecture.md "Safety").
enum class AbortConnectionOption : std::int16_t {
  kNoAction = 0,
  kFaultSignal = 1,
  kDisableVoltage = 2,
  kQuickStop = 3,
};
// 605Ah quick stop option. 1..4: stop then Switch on disabled; 5..8: stop, stay in Quick
// stop active. Torque modes use the current-limit variants.
enum class QuickStopOption : std::int16_t {
  kDisableDrive = 0,
  kSlowDownRamp = 1,
  kQuickStopRamp = 2,
  kCurrentLimit = 3,
  kVoltageLimit = 4,
  kSlowDownRampStay = 5,
  kQuickStopRampStay = 6,
  kCurrentLimitStay = 7,
  kVoltageLimitStay = 8,
};
// 605Bh shutdown option and 605Ch disable operation option.
enum class ShutdownOption : std::int16_t { kDisableDrive = 0, kSlowDownRamp = 1 };
// 605Dh halt option.
enum class HaltOption : std::int16_t {
  kSlowDownRamp = 1,
  kQuickStopRamp = 2,
  kCurrentLimit = 3,
  kVoltageLimit = 4,
};
// 605Eh fault reaction option.
enum class FaultReactionOption : std::int16_t {
  kDisableDrive = 0,  // motor free to rotate
  kSlowDownRamp = 1,
  kQuickStopRamp = 2,
  kCurrentLimit = 3,
  kVoltageLimit = 4,
};

}  // namespace dualv::fw
