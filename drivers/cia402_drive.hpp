#pragma once
// One drive's CiA 402 state machine, host side (CiA 402-2 6.2, "PDS FSA"): walks the drive
// to the state a request asks for with fw::next_transition() (never transition 16), one
// transition at a time, each with a timeout; fault reset on a rising edge of controlword
// bit 7; quick stop; disable. It only computes controlwords: the actuator set puts them on
// the wire and feeds back the statuswords.
//
// Rules (docs/architecture.md "What users of similar stacks ask for" 1-3):
//  - Torque is allowed only while the last statusword says Operation enabled AND the host
//    asked for it (goal Operation enabled) AND no fault reset is in progress. Otherwise the
//    target torque is 0: no motion on enable, a stale target is never replayed.
//  - A stop the drive makes on its own (fault, quick stop active, or dropping out of
//    Operation enabled) is reported (own_stop(), own_stops()) and drops the goal: the
//    controlword becomes disable voltage and the drive is never brought back to Operation
//    enabled without a new kEnable request.
//  - kEnable and kFaultReset act on their leading edge (the request differs from the last
//    cycle's): a kEnable held for many cycles enables once, so after an own stop or a
//    transition timeout nothing is retried until the request is given again. kDisable and
//    kQuickStop act every cycle they are given.
//  - In Fault, only kFaultReset acts (bit 7 low for one cycle, then high until the drive
//    leaves Fault or the transition times out; a new kFaultReset request restarts it, so a
//    drive that refused the edge while the fault's cause remained gets a new one); after it
//    the drive stays in Switch on disabled: a reset never restarts motion by itself.
//  - A transition that does not happen within the timeout (time spent in one state while
//    walking) is reported (transition_timed_out()), the goal is dropped and the
//    controlword becomes disable voltage.
//
// Real-time safe: noexcept, no allocation. Call order per cycle: on_statusword() (read),
// then update() (write).
#include <cstdint>

#include "drivers/actuator_set.hpp"
#include "firmware_if/cia402.hpp"

namespace dualv::drivers {

// Why the drive stopped on its own.
enum class StopCause : std::uint8_t {
  kNone = 0,
  kFault,      // Fault reaction active / Fault (an EMCY usually says why)
  kQuickStop,  // Quick stop active without a host request (e.g. 6007h on connection loss)
  kDisabled,   // left Operation enabled to a disabled state (e.g. STO input, 605Ch)
  kLost,       // statusword no longer known (heartbeat lost, bus-off, node reset)
};
const char* to_string(StopCause c) noexcept;

// What the host is steering the drive towards.
enum class Cia402Goal : std::uint8_t {
  kNone = 0,          // hold: keep the controlword, no walk
  kOperationEnabled,  // kEnable
  kSwitchOnDisabled,  // kDisable, and after a fault reset
  kQuickStopActive,   // kQuickStop
};

struct Cia402Output {
  std::uint16_t controlword = 0;
  bool torque_allowed = false;  // false: send target torque 0
};

class Cia402Drive {
 public:
  Cia402Drive() noexcept = default;
  explicit Cia402Drive(std::uint64_t transition_timeout_ns) noexcept
      : timeout_ns_(transition_timeout_ns) {}
  void set_transition_timeout(std::uint64_t ns) noexcept { timeout_ns_ = ns; }

  // A statusword received (TPDO1). Decodes the state, detects own stops.
  void on_statusword(std::uint16_t statusword, std::uint64_t now_ns) noexcept;
  // The state is no longer known (heartbeat timeout, bus-off, boot-up of the node).
  void on_lost() noexcept;
  // Applies this cycle's request and returns the controlword to send.
  Cia402Output update(DriveRequest request, std::uint64_t now_ns) noexcept;

  bool known() const noexcept { return known_; }
  fw::Cia402State state() const noexcept { return state_; }
  std::uint16_t statusword() const noexcept { return statusword_; }
  std::uint16_t controlword() const noexcept { return controlword_; }
  Cia402Goal goal() const noexcept { return goal_; }
  bool fault_reset_in_progress() const noexcept { return reset_phase_ != ResetPhase::kIdle; }
  // The last stop the drive made on its own; cleared by the next kEnable.
  StopCause own_stop() const noexcept { return own_stop_; }
  std::uint64_t own_stops() const noexcept { return own_stops_; }
  // Latched until the next new request other than kHold.
  bool transition_timed_out() const noexcept { return timed_out_; }
  std::uint64_t transition_timeouts() const noexcept { return transition_timeouts_; }
  std::uint64_t fault_resets() const noexcept { return fault_resets_; }
  std::uint64_t bad_statuswords() const noexcept { return bad_statuswords_; }
  // Number of the transition last commanded (CiA 402-2 figure 22), 0 if none.
  std::uint8_t last_transition() const noexcept { return last_transition_; }

  // The DriveState the layers above see.
  DriveState drive_state() const noexcept;

 private:
  enum class ResetPhase : std::uint8_t { kIdle, kLow, kHigh };
  void own_stop(StopCause c) noexcept;
  void time_out() noexcept;

  std::uint64_t timeout_ns_ = 500'000'000;
  bool known_ = false;
  fw::Cia402State state_ = fw::Cia402State::kNotReadyToSwitchOn;
  std::uint16_t statusword_ = 0;
  std::uint16_t controlword_ = 0;  // disable voltage until told otherwise
  Cia402Goal goal_ = Cia402Goal::kNone;
  ResetPhase reset_phase_ = ResetPhase::kIdle;
  std::uint64_t state_since_ns_ = 0;  // when the current state (or walk step) began
  bool timed_out_ = false;
  StopCause own_stop_ = StopCause::kNone;
  std::uint8_t last_transition_ = 0;
  DriveRequest last_request_ = DriveRequest::kHold;
  std::uint64_t own_stops_ = 0;
  std::uint64_t transition_timeouts_ = 0;
  std::uint64_t fault_resets_ = 0;
  std::uint64_t bad_statuswords_ = 0;
};

}  // namespace dualv::drivers
