#pragma once
// A CanBus that holds the frames sent to it until flush() and then hands them to the bus
// underneath in one batch (CanBus::send_many: one sendmmsg on SocketCAN), and reads in
// batches (receive_many). For a process that answers many frames per wake-up and whose
// answers need not go out one by one: `dualv sim` (apps/cmd_sim.cpp) sends the four drives'
// TPDOs of a SYNC in one syscall instead of four, which is what decides whether the
// emulator keeps up in the user-mode-linux HIL guest (tests/hil/README.md).
//
// Not for the master's cycle: CanopenActuatorSet batches its own frames and needs each
// frame's outcome (drivers/canopen_actuator_set.cpp). Here send() only queues (kOk; a full
// queue is flushed first); a frame the bus refuses at flush() is dropped and counted by the
// bus underneath (its counters().tx_dropped), as a refused send() would be.
// Real-time safe: fixed buffers, noexcept, nothing allocated.
#include <array>
#include <cstddef>

#include "drivers/can/can_bus.hpp"

namespace dualv::drivers {

class BatchingBus final : public CanBus {
 public:
  explicit BatchingBus(CanBus& inner) noexcept : inner_(inner) {}

  BusStatus send(const fw::CanFrame& frame) noexcept override;
  BusStatus receive(fw::CanFrame& frame) noexcept override;
  BusStatus state() const noexcept override { return inner_.state(); }
  // Drops what is queued either way (never sent late), then restarts the bus underneath.
  BusStatus restart() noexcept override;
  const BusCounters& counters() const noexcept override { return inner_.counters(); }

  // Sends every queued frame in order; a refused frame is dropped and the next tried, until
  // bus-off. Returns kOk or the first refusal's status.
  BusStatus flush() noexcept;
  std::size_t queued() const noexcept { return tx_count_; }

 private:
  static constexpr std::size_t kCapacity = 64;
  CanBus& inner_;
  std::array<fw::CanFrame, kCapacity> tx_{};
  std::size_t tx_count_ = 0;
  std::array<fw::CanFrame, kCapacity> rx_{};
  std::size_t rx_next_ = 0;
  std::size_t rx_count_ = 0;
  bool rx_short_ = false;  // the last receive_many found the queue empty
};

}  // namespace dualv::drivers
