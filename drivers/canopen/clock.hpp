#pragma once
// The clock every CANopen timeout is measured with, injected so tests step time themselves
// (never sleeping) and every timeout is checked at T-1 and T exactly (docs/architecture.md
// "Safety"). now_ns() is monotonic; noexcept and allocation-free (real-time safe).
#include <chrono>
#include <cstdint>

namespace dualv::drivers::canopen {

class Clock {
 public:
  virtual ~Clock() = default;
  virtual std::uint64_t now_ns() const noexcept = 0;
};

// CLOCK_MONOTONIC (std::chrono::steady_clock): real drives and the vcan tests.
class SteadyClock final : public Clock {
 public:
  std::uint64_t now_ns() const noexcept override {
    return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                          std::chrono::steady_clock::now().time_since_epoch())
                                          .count());
  }
};

// Time set by the owner (tests, the in-process simulation).
class ManualClock final : public Clock {
 public:
  explicit ManualClock(std::uint64_t start_ns = 0) noexcept : now_(start_ns) {}
  std::uint64_t now_ns() const noexcept override { return now_; }
  void set_ns(std::uint64_t t) noexcept { now_ = t; }
  void advance_ns(std::uint64_t dt) noexcept { now_ += dt; }

 private:
  std::uint64_t now_ = 0;
};

// Elapsed-time check used by every timeout: expired at exactly `timeout` after `start`.
constexpr bool expired(std::uint64_t start_ns, std::uint64_t now_ns,
                       std::uint64_t timeout_ns) noexcept {
  return now_ns >= start_ns && now_ns - start_ns >= timeout_ns;
}

}  // namespace dualv::drivers::canopen
