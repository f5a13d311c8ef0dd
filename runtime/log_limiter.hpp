#pragma once
// A log rate limit for messages a peer can trigger at will (garbage on the command channel,
// issue 14 defect 6): the first `burst` events are logged in full, the rest only counted,
// and at most one summary line per `interval_us` says how many were not logged. After an
// interval without a suppressed event the burst is available again. The clock is the
// caller's (us), so a test drives it; nothing here allocates or locks.
#include <cstdint>

namespace dualv::runtime {

class LogLimiter {
 public:
  LogLimiter(std::uint64_t burst, std::int64_t interval_us) noexcept
      : burst_(burst), interval_us_(interval_us) {}

  // One event at `now_us`: true when it is to be logged in full.
  bool allow(std::int64_t now_us) noexcept {
    if (suppressed_ == 0 && now_us - window_start_ >= interval_us_) {
      window_start_ = now_us;  // quiet for an interval: a fresh burst
      logged_in_window_ = 0;
    }
    if (logged_in_window_ < burst_) {
      ++logged_in_window_;
      return true;
    }
    if (suppressed_ == 0) window_start_ = now_us;  // the summary interval starts here
    ++suppressed_;
    return false;
  }

  // The number of events not logged since the last summary when a summary is due (an
  // interval has passed since the first of them, or `force`), else 0. Resets the count.
  std::uint64_t take_summary(std::int64_t now_us, bool force = false) noexcept {
    if (suppressed_ == 0 || (!force && now_us - window_start_ < interval_us_)) return 0;
    const std::uint64_t n = suppressed_;
    suppressed_ = 0;
    window_start_ = now_us;
    return n;
  }

 private:
  std::uint64_t burst_;
  std::int64_t interval_us_;
  std::int64_t window_start_ = INT64_MIN / 2;
  std::uint64_t logged_in_window_ = 0;
  std::uint64_t suppressed_ = 0;
};

}  // namespace dualv::runtime
