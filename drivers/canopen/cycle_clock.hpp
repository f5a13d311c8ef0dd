#pragma once
// The CANopen clock of a cyclic master: inside a cycle, the time the control loop woke for it
// (CycleInfo::wake_ns, control/loop/periodic_executive.hpp, read once by the executive), so the
// actuator set's read() and write() of a cycle make no clock read of their own; outside a cycle
// (boot, priming, shut-down) the base clock. Where each clock read is a system call (no vDSO,
// as in the user-mode-linux HIL guest: tests/hil/README.md "What a cycle costs in the guest")
// that is one system call less per cycle. The loop's clock and `base` must be the same clock
// (CLOCK_MONOTONIC: control::MonotonicClock and SteadyClock).
// Real-time safe: noexcept, no allocation, no lock (an atomic: other threads may read it).
#include <atomic>
#include <cstdint>

#include "drivers/canopen/clock.hpp"

namespace dualv::drivers::canopen {

class CycleClock final : public Clock {
 public:
  explicit CycleClock(const Clock& base) noexcept : base_(base) {}
  std::uint64_t now_ns() const noexcept override {
    const std::uint64_t t = cycle_ns_.load(std::memory_order_relaxed);
    return t != 0 ? t : base_.now_ns();
  }
  // The loop's thread, before the cycle's read() and after its write().
  void begin_cycle(std::uint64_t wake_ns) noexcept {
    cycle_ns_.store(wake_ns != 0 ? wake_ns : 1, std::memory_order_relaxed);
  }
  void end_cycle() noexcept { cycle_ns_.store(0, std::memory_order_relaxed); }

 private:
  const Clock& base_;
  std::atomic<std::uint64_t> cycle_ns_{0};  // 0: not in a cycle
};

}  // namespace dualv::drivers::canopen
