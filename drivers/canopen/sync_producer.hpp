#pragma once
// SYNC producer (CiA 301 7.2.5): one SYNC per control cycle on 080h, optionally with the
// counter 1..overflow (1019h). The counter advances only for a SYNC that was handed to the
// bus, so a failed send (ENOBUFS) never makes the drives see a counter jump.
// Real-time safe: noexcept, no allocation.
#include <cstdint>

#include "drivers/can/can_bus.hpp"
#include "firmware_if/result.hpp"

namespace dualv::drivers::canopen {

class SyncProducer {
 public:
  explicit SyncProducer(std::uint8_t counter_overflow = 0) noexcept : overflow_(counter_overflow) {}
  BusStatus send(CanBus& bus) noexcept;
  // The same in two steps, for a caller that sends a cycle's frames in one batch
  // (CanBus::send_many): the next SYNC's frame, then what became of it.
  fw::Result<fw::CanFrame> next_frame() const noexcept;
  void on_sent(BusStatus status) noexcept;
  // Counter of the last SYNC sent (0 before the first, or without counter).
  std::uint8_t counter() const noexcept { return counter_; }
  std::uint8_t overflow() const noexcept { return overflow_; }
  std::uint64_t sent() const noexcept { return sent_; }
  std::uint64_t failed() const noexcept { return failed_; }

 private:
  std::uint8_t overflow_ = 0;
  std::uint8_t counter_ = 0;
  std::uint64_t sent_ = 0;
  std::uint64_t failed_ = 0;
};

}  // namespace dualv::drivers::canopen
