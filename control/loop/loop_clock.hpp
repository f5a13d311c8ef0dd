#pragma once
// The clock the periodic executive sleeps on, injectable so that tests and the
// in-process simulation step time themselves instead of sleeping.
//
// Real-time safety: every member is noexcept and allocation-free; the only
// syscalls are clock_gettime and clock_nanosleep (docs/architecture.md "Rules for the
// real-time path").
#include <cstdint>

namespace dualv::control {

class LoopClock {
 public:
  virtual ~LoopClock() = default;
  // Monotonic time in nanoseconds (arbitrary epoch).
  virtual std::int64_t now_ns() noexcept = 0;
  // Returns at or after absolute time t_ns (immediately when already past).
  virtual void sleep_until_ns(std::int64_t t_ns) noexcept = 0;
};

// CLOCK_MONOTONIC with clock_nanosleep(TIMER_ABSTIME): absolute wake-ups do not
// accumulate drift the way relative sleeps do, and EINTR is retried against
// the same absolute time.
class MonotonicClock final : public LoopClock {
 public:
  std::int64_t now_ns() noexcept override;
  void sleep_until_ns(std::int64_t t_ns) noexcept override;
};

// Simulated time that never sleeps: sleep_until jumps to the wake-up time, so a
// simulation runs as fast as the CPU allows and a test is fully deterministic.
// Work inside a cycle takes no time unless the test says so with advance(); a
// late wake-up is injected with set_wake_latency().
class SimClock final : public LoopClock {
 public:
  explicit SimClock(std::int64_t start_ns = 0) noexcept : now_(start_ns) {}
  std::int64_t now_ns() noexcept override { return now_; }
  void sleep_until_ns(std::int64_t t_ns) noexcept override {
    if (t_ns > now_) now_ = t_ns;
    now_ += wake_latency_;
    ++sleeps_;
  }
  void advance(std::int64_t dt_ns) noexcept { now_ += dt_ns; }
  // Added to every following wake-up (0 = wake exactly on time).
  void set_wake_latency(std::int64_t ns) noexcept { wake_latency_ = ns; }
  std::int64_t sleeps() const noexcept { return sleeps_; }

 private:
  std::int64_t now_;
  std::int64_t wake_latency_ = 0;
  std::int64_t sleeps_ = 0;
};

}  // namespace dualv::control
