#pragma once
// Cycle-time and lateness statistics of the periodic executive, recorded every
// cycle into fixed histograms allocated at construction: record() is noexcept,
// O(1) and never allocates, so it runs inside the real-time cycle for runs of
// any length (a sample buffer would grow or wrap; a histogram does neither).
//
// Percentiles use the nearest-rank definition and are conservative: a sample v
// falls in bin ceil(v / resolution), the bin reports its upper edge, clamped to
// the exact [min, max] seen. Values that are multiples of the resolution are
// therefore reported exactly; others are rounded up by less than one bin.
// Samples beyond the range land in an overflow bin that reports the exact max.
#include <cstdint>
#include <string>
#include <vector>

namespace dualv::control {

// Five-number summary of one timing quantity, in nanoseconds.
struct TimingSummary {
  std::int64_t min_ns = 0;
  std::int64_t median_ns = 0;
  std::int64_t p99_ns = 0;
  std::int64_t p999_ns = 0;
  std::int64_t max_ns = 0;
};

// Everything the executive reports about a run (published as loop_stats_t).
struct LoopStatsSummary {
  std::int64_t period_ns = 0;
  std::int64_t deadline_ns = 0;
  std::int64_t resolution_ns = 0;
  std::int64_t cycles = 0;
  TimingSummary cycle;     // duration of the cycle work
  TimingSummary lateness;  // wake-up time minus scheduled release time
  std::int64_t deadline_misses = 0;
  std::int64_t overruns = 0;  // release points skipped
  std::int32_t consecutive_misses = 0;
  std::int32_t max_consecutive_misses = 0;
};

// Multi-line human-readable report of a run (set-up/teardown code: allocates),
// e.g. for the end of `dualv run`:
//   loop: 60000 cycles at 1000 Hz (deadline 1000 us), 0 deadline misses, 0 overruns
//     cycle time  min 12.0  median 15.0  p99 21.0  p99.9 40.0  max 95.0 us
//     lateness    min 2.0  median 8.0  p99 30.0  p99.9 55.0  max 120.0 us
std::string format_loop_stats(const LoopStatsSummary& s);

class TimingHistogram {
 public:
  // Set-up: throws std::invalid_argument unless 0 < resolution <= range.
  TimingHistogram(std::int64_t resolution_ns, std::int64_t range_ns);

  void add(std::int64_t v_ns) noexcept;
  void reset() noexcept;
  std::int64_t count() const noexcept { return count_; }
  // Nearest-rank percentile for a fraction given in parts per 10000 (5000 =
  // median, 9990 = p99.9): integer ranks, so p99.9 of 1000 samples is exactly
  // the 999th smallest. 0 when empty.
  std::int64_t percentile(std::int64_t parts_per_10000) const noexcept;
  TimingSummary summary() const noexcept;
  std::int64_t resolution_ns() const noexcept { return resolution_; }

 private:
  std::int64_t resolution_;
  std::vector<std::int64_t> bins_;  // last bin = overflow
  std::int64_t count_ = 0;
  std::int64_t min_ = 0;
  std::int64_t max_ = 0;
};

class CycleStats {
 public:
  // deadline_ns <= 0 means "deadline = period". Throws std::invalid_argument
  // on a non-positive period or resolution (set-up only).
  CycleStats(std::int64_t period_ns, std::int64_t deadline_ns, std::int64_t resolution_ns,
             std::int64_t range_ns);

  // One cycle: lateness (wake - release), duration of the work and response
  // (completion - release). A cycle misses its deadline when response >
  // deadline: completing exactly at the deadline meets it. Returns whether it
  // missed. Real-time safe.
  bool record(std::int64_t lateness_ns, std::int64_t cycle_ns, std::int64_t response_ns) noexcept;
  void add_overruns(std::int64_t skipped_releases) noexcept { overruns_ += skipped_releases; }
  void reset() noexcept;

  std::int64_t cycles() const noexcept { return cycle_.count(); }
  std::int64_t deadline_misses() const noexcept { return misses_; }
  std::int32_t consecutive_misses() const noexcept { return consecutive_; }
  std::int64_t period_ns() const noexcept { return period_; }
  std::int64_t deadline_ns() const noexcept { return deadline_; }
  // Scans the histograms: O(range / resolution). Real-time safe but not free
  // (about 10 us for the default 20 ms / 1 us): call it every second or so,
  // not every cycle.
  LoopStatsSummary summary() const noexcept;

 private:
  std::int64_t period_;
  std::int64_t deadline_;
  TimingHistogram cycle_;
  TimingHistogram lateness_;
  std::int64_t misses_ = 0;
  std::int64_t overruns_ = 0;
  std::int32_t consecutive_ = 0;
  std::int32_t max_consecutive_ = 0;
};

}  // namespace dualv::control
