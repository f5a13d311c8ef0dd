#pragma once
// A CANopen slave's EMCY producer (CiA 301 7.2.7) and the error register 1001h it owns
// (7.5.2.2), like CANopenNode's CO_Emergency: the application reports error conditions by a
// number of its own (0..kEmcyConditions-1); 1001h is the OR of every active condition's
// bits (generic + the class of its error code: current 2xxxh, voltage 3xxxh, temperature
// 4xxxh, communication 8xxxh). A condition that starts sends EMCY (error code, 1001h, 5
// zero bytes) on 080h + node; one that is gone sends the error reset EMCY 0000h with what
// remains in 1001h. `announce` false updates 1001h only (NMT Stopped or Initialisation, no
// EMCY: the caller knows, CiA 301 7.3.2.2 table 75; or a reaction that reports itself
// otherwise). noexcept, no allocation (tests/sim/canopen/emcy_producer_test.cpp).
#include <array>
#include <cstdint>

#include "sim/canopen/frame_sink.hpp"
#include "sim/canopen/object_dictionary.hpp"

namespace dualv::sim::canopen {

inline constexpr int kEmcyConditions = 8;

// 1001h bits for an error code's class (CiA 301 7.5.2.2, table 21 classes).
std::uint8_t error_register_bits(std::uint16_t error_code) noexcept;

class EmcyProducer {
 public:
  // `error_register_slot`: 1001h in the slave's dictionary.
  void attach(std::uint8_t node, int error_register_slot) noexcept {
    node_ = node;
    slot_ = error_register_slot;
  }
  // Condition `condition` is present with `error_code` (raised again: the EMCY again).
  void raise(ObjectDictionary& od, int condition, std::uint16_t error_code, bool announce,
             FrameSink& sink) noexcept;
  // Condition `condition` is gone: nothing when it was not active, else 1001h updated and,
  // with `announce`, EMCY 0000h with the remaining register.
  void clear(ObjectDictionary& od, int condition, bool announce, FrameSink& sink) noexcept;
  // Every condition gone without a message (NMT reset node: 1001h is reset with the dictionary).
  void reset() noexcept { active_.fill(false); }
  bool active(int condition) const noexcept {
    return condition >= 0 && condition < kEmcyConditions &&
           active_[static_cast<std::size_t>(condition)];
  }
  std::uint8_t error_register() const noexcept;
  std::uint64_t sent() const noexcept { return sent_; }

 private:
  void emit(ObjectDictionary& od, std::uint16_t code, bool announce, FrameSink& sink) noexcept;

  std::uint8_t node_ = 1;
  int slot_ = -1;
  std::array<bool, kEmcyConditions> active_{};
  std::array<std::uint16_t, kEmcyConditions> code_{};
  std::uint64_t sent_ = 0;
};

}  // namespace dualv::sim::canopen
