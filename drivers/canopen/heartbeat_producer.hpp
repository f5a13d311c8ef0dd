#pragma once
// The master's own heartbeat (CiA 301 7.2.8.3.2.2) on 700h + master node id. The drives
// consume it (their 1016h, written at boot) and stop on their own (6007h abort connection
// option) when the host dies (docs/architecture.md users #4). Real-time safe.
#include <cstdint>

#include "drivers/can/can_bus.hpp"
#include "firmware_if/nmt.hpp"
#include "firmware_if/result.hpp"

namespace dualv::drivers::canopen {

class HeartbeatProducer {
 public:
  HeartbeatProducer(std::uint8_t node, std::uint64_t period_ns) noexcept
      : node_(node), period_ns_(period_ns) {}
  // Sends a heartbeat when one is due (the first poll sends at once), else returns kOk.
  // A failed send is retried at the next poll.
  BusStatus poll(CanBus& bus, std::uint64_t now_ns,
                 fw::NmtState state = fw::NmtState::kOperational) noexcept;
  // The same in steps, for a caller that sends a cycle's frames in one batch
  // (CanBus::send_many): whether a heartbeat is due, then what became of it.
  bool due(std::uint64_t now_ns) const noexcept;
  void on_sent(BusStatus status, std::uint64_t now_ns) noexcept;
  std::uint64_t sent() const noexcept { return sent_; }
  std::uint64_t failed() const noexcept { return failed_; }
  std::uint8_t node() const noexcept { return node_; }

 private:
  std::uint8_t node_;
  std::uint64_t period_ns_;
  std::uint64_t last_ns_ = 0;
  bool started_ = false;
  std::uint64_t sent_ = 0;
  std::uint64_t failed_ = 0;
};

}  // namespace dualv::drivers::canopen
