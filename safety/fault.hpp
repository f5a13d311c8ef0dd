#pragma once
// Every fault the safety layer detects and the ONE table that says how it reacts
// (docs/safety.md prints the same table; tests/safety/fault_table_test.cpp checks that the two
// agree). Stop reactions after IEC 61800-5-2, stop categories after IEC 60204-1 9.2.2:
//
//   kSto   Safe torque off, stop category 0: target torque 0 and CiA 402 "disable voltage"
//          (drivers::DriveRequest::kDisable, transitions 7/9/10/12) in the detection cycle.
//          The mechanism coasts (friction only).
//   kSs1   Safe stop 1, stop category 1: a controlled deceleration (joint-space velocity
//          damping, torque and rate limited) until standstill or the configured time, then
//          STO. Used when the loop can still measure and command (limits, e-stop requests).
//   kWarn  Logged and counted, no stop (a single deadline miss).
//
// This is software: none of it is a certified safety function. The machine's emergency stop
// is the hardwired circuit to the drives' STO inputs (IEC 60204-1 9.2.5.4.2, IEC 61800-5-2);
// the software watches that circuit (kEstopInput) and stops the rest of the system with it.
#include <array>
#include <cstdint>

namespace dualv::safety {

enum class Reaction : std::uint8_t { kWarn = 0, kSs1, kSto };
const char* to_string(Reaction r) noexcept;

// How a latched cause clears (a reset is refused while any latched cause is still active).
enum class Clearing : std::uint8_t {
  kOnReset = 0,  // a momentary event (a request, a bad command): the reset command clears it
  kCondition,    // a condition the cycle re-evaluates: clears only once it has gone
};

enum class Fault : std::uint8_t {
  kEstopLcm = 0,        // e-stop message on the LCM command channel
  kEstopSignal,         // SIGINT / SIGTERM to the controller process
  kEstopCli,            // the operator console / `dualv estop` on this host
  kEstopInput,          // hardwired e-stop circuit open, seen on a drive input (60FDh)
  kDriveLost,           // a drive offline: heartbeat timeout (1017h/1016h), NMT not operational
  kDriveFault,          // a drive in Fault / Fault reaction active (EMCY, 603Fh)
  kBusError,            // bus-off or a send failure (CAN controller), CiA 301 error passive/off
  kStaleFeedback,       // no fresh position (TPDO) for stale_feedback_cycles cycles
  kEncoderJump,         // a position step no motion can explain (sensor fault)
  kInvalidState,        // NaN/Inf position or a failed pose estimate (forward kinematics)
  kDeadlineMiss,        // the cycle finished after its deadline (one)
  kDeadlineMisses,      // max_consecutive_deadline_misses consecutive misses
  kSafetyCheckMissed,   // the write path found the safety check did not run (or was bypassed)
  kNonFiniteCommand,    // NaN/Inf in the controller's torque command
  kTorqueLimit,         // |tau| above safety.torque.max (clamped in the same cycle)
  kTorqueRate,          // |d tau / dt| above safety.torque.max_rate (limited in the same cycle)
  kJointVelocity,       // |q_dot| above max_joint_velocity (SLS-like monitor)
  kPlateVelocity,       // plate speed or angular speed above its limit
  kWorkspace,           // plate pose outside the x/y box or the theta range
  kSingularity,         // parallel or serial singularity measure below its minimum
  kTrackingError,       // |X_d - X| above max_tracking_error (position or angle)
  kCommandStreamStale,  // streaming mode active and no LCM command for the timeout
  kStopTimeout,         // SS1 did not reach standstill within ss1.max_time: STO anyway
  kCount
};
inline constexpr int kFaultCount = static_cast<int>(Fault::kCount);

const char* to_string(Fault f) noexcept;

struct FaultRule {
  Fault fault;
  Reaction reaction;
  Clearing clearing;
};

// THE fault -> reaction table (one entry per Fault, in enum order).
inline constexpr std::array<FaultRule, kFaultCount> kFaultTable{{
    {Fault::kEstopLcm, Reaction::kSs1, Clearing::kOnReset},
    {Fault::kEstopSignal, Reaction::kSs1, Clearing::kOnReset},
    {Fault::kEstopCli, Reaction::kSs1, Clearing::kOnReset},
    // The hardwired circuit has already removed the drives' power (STO, category 0 or 1 in
    // hardware): the software follows with disable so nothing re-enables behind it.
    {Fault::kEstopInput, Reaction::kSto, Clearing::kCondition},
    {Fault::kDriveLost, Reaction::kSto, Clearing::kCondition},
    {Fault::kDriveFault, Reaction::kSto, Clearing::kCondition},
    {Fault::kBusError, Reaction::kSto, Clearing::kCondition},
    {Fault::kStaleFeedback, Reaction::kSto, Clearing::kCondition},
    {Fault::kEncoderJump, Reaction::kSto, Clearing::kOnReset},
    {Fault::kInvalidState, Reaction::kSto, Clearing::kCondition},
    {Fault::kDeadlineMiss, Reaction::kWarn, Clearing::kOnReset},
    {Fault::kDeadlineMisses, Reaction::kSto, Clearing::kOnReset},
    {Fault::kSafetyCheckMissed, Reaction::kSto, Clearing::kOnReset},
    // SS1's damping torque does not use the controller's output, so a bad command can
    // still be answered by a controlled stop.
    {Fault::kNonFiniteCommand, Reaction::kSs1, Clearing::kOnReset},
    {Fault::kTorqueLimit, Reaction::kSs1, Clearing::kOnReset},
    {Fault::kTorqueRate, Reaction::kSs1, Clearing::kOnReset},
    {Fault::kJointVelocity, Reaction::kSs1, Clearing::kCondition},
    {Fault::kPlateVelocity, Reaction::kSs1, Clearing::kCondition},
    {Fault::kWorkspace, Reaction::kSs1, Clearing::kCondition},
    {Fault::kSingularity, Reaction::kSs1, Clearing::kCondition},
    {Fault::kTrackingError, Reaction::kSs1, Clearing::kOnReset},
    {Fault::kCommandStreamStale, Reaction::kSs1, Clearing::kOnReset},
    {Fault::kStopTimeout, Reaction::kSto, Clearing::kOnReset},
}};

constexpr bool table_in_enum_order() noexcept {
  for (int i = 0; i < kFaultCount; ++i)
    if (static_cast<int>(kFaultTable[static_cast<std::size_t>(i)].fault) != i) return false;
  return true;
}
static_assert(table_in_enum_order(), "kFaultTable must list every Fault once, in enum order");

constexpr const FaultRule& rule(Fault f) noexcept {
  return kFaultTable[static_cast<std::size_t>(f)];
}
constexpr Reaction reaction_of(Fault f) noexcept { return rule(f).reaction; }

// A set of faults as bits (bit i = Fault i).
using FaultSet = std::uint32_t;
static_assert(kFaultCount <= 32, "FaultSet holds one bit per fault");
constexpr FaultSet bit(Fault f) noexcept { return FaultSet{1} << static_cast<unsigned>(f); }

// The strongest reaction any fault of `set` asks for (kWarn for an empty set).
constexpr Reaction strongest(FaultSet set) noexcept {
  Reaction r = Reaction::kWarn;
  for (int i = 0; i < kFaultCount; ++i)
    if ((set >> i) & 1u) {
      const Reaction ri = kFaultTable[static_cast<std::size_t>(i)].reaction;
      if (static_cast<int>(ri) > static_cast<int>(r)) r = ri;
    }
  return r;
}

}  // namespace dualv::safety
