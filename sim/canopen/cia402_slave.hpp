#pragma once
// The drive side of the CiA 402 state machine (CiA 402-2 6.2 / 6.3), derived from
// firmware_if's one transition table (fw::slave_transition, fw::statusword_bits): the
// controlword 6040h walks transitions 2..12 and 16 (only when 605Ah is 5..8), 15 on the
// rising edge of bit 7 only (refused while the fault's cause remains); quick stop with the
// 605Ah reaction (0: on to Switch on disabled at once, 1..4: at the next SYNC, "stopped",
// the ramp not modelled; 5..8: stays in Quick stop active); a fault passes Fault reaction
// active (13) into Fault (14) at once; disable voltage from every power state (7, 10, 9,
// 12). Statusword: the state's pattern + remote (bit 9), voltage enabled (bit 4) in Switched
// on / Operation enabled / Quick stop active, and the application's bits. The application
// (sim/drive_emulator.cpp) does what a state means (torque on only in Operation enabled).
// noexcept, no allocation (tests/sim/canopen/cia402_slave_test.cpp).
#include <cstdint>

#include "firmware_if/cia402.hpp"

namespace dualv::sim::canopen {

// What a controlword did.
enum class ControlwordEffect : std::uint8_t {
  kNone,               // no transition (or not in this state)
  kTransition,         // a transition of the table (last_transition())
  kFaultReset,         // 15: Fault -> Switch on disabled; the application clears 603Fh
  kFaultResetRefused,  // 15 asked while the cause remains
};

class Cia402Slave {
 public:
  fw::Cia402State state() const noexcept { return state_; }
  std::uint8_t last_transition() const noexcept { return last_transition_; }
  // Power-on or NMT reset node: 0 then 1 (Switch on disabled), the bit 7 edge forgotten.
  void power_on() noexcept;
  // The controlword was written. `quick_stop_option`: 605Ah; `power_stage_blocked`: the STO
  // circuit is open (transition 2 refused); `fault_cause_remains`: 15 refused.
  ControlwordEffect on_controlword(std::uint16_t controlword, std::int16_t quick_stop_option,
                                   bool power_stage_blocked, bool fault_cause_remains) noexcept;
  // Quick stop active entered (transition 11, or a 6007h reaction); 605Ah decides the rest.
  void quick_stop(std::int16_t quick_stop_option) noexcept;
  // Voltage off from whatever power state (7, 10, 9, 12); false when there is none.
  bool disable_voltage() noexcept;
  // A fault: 13 and 14 (nothing when already in Fault); false when already in Fault.
  bool fault() noexcept;
  // A SYNC: a quick stop with 605Ah 1..4 has "stopped" (12).
  void on_sync() noexcept;
  // Statusword 6041h: pattern + remote + voltage enabled, plus `extra` bits of the
  // application (drive follows the command, internal limit, warning).
  std::uint16_t statusword(std::uint16_t extra = 0) const noexcept;

 private:
  void go(fw::Cia402State to, std::uint8_t transition) noexcept;

  fw::Cia402State state_ = fw::Cia402State::kNotReadyToSwitchOn;
  std::uint8_t last_transition_ = 0;
  std::uint16_t previous_controlword_ = 0;  // bit 7 edge detection
  bool quick_stop_to_disabled_ = false;
};

}  // namespace dualv::sim::canopen
