#pragma once
// How non-real-time set-up code (CanopenMaster's blocking helpers) waits for frames: it
// never sleeps on its own. SocketCanWaiter polls the socket; tests supply a waiter that
// runs the scripted fake drives and advances a ManualClock, so boot and SDO tests are
// deterministic.
#include <algorithm>
#include <chrono>
#include <cstdint>

#include "drivers/can/socketcan_bus.hpp"
#include "drivers/canopen/clock.hpp"

namespace dualv::drivers::canopen {

class Waiter {
 public:
  virtual ~Waiter() = default;
  // Returns when a frame may be ready or the clock reached `deadline_ns` (whichever first;
  // returning early is always allowed).
  virtual void wait_until(std::uint64_t deadline_ns) = 0;
};

// Blocks in poll() on the socket, at most `slice` at a time (the master's heartbeat keeps
// going during long waits).
class SocketCanWaiter final : public Waiter {
 public:
  SocketCanWaiter(const SocketCanBus& bus, const Clock& clock,
                  std::chrono::nanoseconds slice = std::chrono::milliseconds(5)) noexcept
      : bus_(bus), clock_(clock), slice_(slice) {}
  void wait_until(std::uint64_t deadline_ns) override {
    const std::uint64_t now = clock_.now_ns();
    if (now >= deadline_ns) return;
    const auto left = std::chrono::nanoseconds(deadline_ns - now);
    (void)bus_.wait_readable(std::min(left, slice_));
  }

 private:
  const SocketCanBus& bus_;
  const Clock& clock_;
  std::chrono::nanoseconds slice_;
};

}  // namespace dualv::drivers::canopen
