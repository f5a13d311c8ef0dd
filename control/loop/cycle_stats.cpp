#include "control/loop/cycle_stats.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>
#include <string>

namespace dualv::control {

std::string format_loop_stats(const LoopStatsSummary& s) {
  auto us = [](std::int64_t ns) { return static_cast<double>(ns) * 1e-3; };
  auto line = [&](const char* name, const TimingSummary& t) {
    return fmt::format(
        "  {:<11} min {:.1f}  median {:.1f}  p99 {:.1f}  p99.9 {:.1f}  max {:.1f} us\n", name,
        us(t.min_ns), us(t.median_ns), us(t.p99_ns), us(t.p999_ns), us(t.max_ns));
  };
  std::string out = fmt::format(
      "loop: {} cycles at {:.0f} Hz (deadline {:.0f} us), {} deadline misses (longest run {}), "
      "{} overruns\n",
      s.cycles, s.period_ns > 0 ? 1e9 / static_cast<double>(s.period_ns) : 0.0, us(s.deadline_ns),
      s.deadline_misses, s.max_consecutive_misses, s.overruns);
  out += line("cycle time", s.cycle);
  out += line("lateness", s.lateness);
  return out;
}

TimingHistogram::TimingHistogram(std::int64_t resolution_ns, std::int64_t range_ns)
    : resolution_(resolution_ns) {
  if (resolution_ns <= 0 || range_ns < resolution_ns)
    throw std::invalid_argument("timing histogram: need 0 < resolution (" +
                                std::to_string(resolution_ns) + " ns) <= range (" +
                                std::to_string(range_ns) + " ns)");
  // Bins 0..range/resolution (rounded up) hold in-range samples, one more is overflow.
  const std::int64_t in_range = (range_ns + resolution_ns - 1) / resolution_ns + 1;
  bins_.assign(static_cast<std::size_t>(in_range + 1), 0);
}

void TimingHistogram::add(std::int64_t v_ns) noexcept {
  if (count_ == 0) {
    min_ = max_ = v_ns;
  } else {
    min_ = std::min(min_, v_ns);
    max_ = std::max(max_, v_ns);
  }
  ++count_;
  // Bin ceil(v / resolution): a bin's upper edge bounds every sample in it.
  const std::int64_t last = static_cast<std::int64_t>(bins_.size()) - 1;
  std::int64_t bin = v_ns <= 0 ? 0 : (v_ns + resolution_ - 1) / resolution_;
  if (bin > last) bin = last;
  ++bins_[static_cast<std::size_t>(bin)];
}

void TimingHistogram::reset() noexcept {
  std::fill(bins_.begin(), bins_.end(), 0);
  count_ = min_ = max_ = 0;
}

std::int64_t TimingHistogram::percentile(std::int64_t parts_per_10000) const noexcept {
  if (count_ == 0) return 0;
  parts_per_10000 = std::clamp<std::int64_t>(parts_per_10000, 0, 10000);
  // Nearest rank: the smallest value with at least p of the samples <= it.
  const std::int64_t rank = std::max<std::int64_t>(1, (count_ * parts_per_10000 + 9999) / 10000);
  const std::size_t last = bins_.size() - 1;
  std::int64_t seen = 0;
  for (std::size_t i = 0; i < bins_.size(); ++i) {
    seen += bins_[i];
    if (seen >= rank) {
      if (i == last) return max_;
      return std::clamp(static_cast<std::int64_t>(i) * resolution_, min_, max_);
    }
  }
  return max_;
}

TimingSummary TimingHistogram::summary() const noexcept {
  TimingSummary s;
  s.min_ns = min_;
  s.median_ns = percentile(5000);
  s.p99_ns = percentile(9900);
  s.p999_ns = percentile(9990);
  s.max_ns = max_;
  return s;
}

CycleStats::CycleStats(std::int64_t period_ns, std::int64_t deadline_ns, std::int64_t resolution_ns,
                       std::int64_t range_ns)
    : period_(period_ns),
      deadline_(deadline_ns > 0 ? deadline_ns : period_ns),
      cycle_(resolution_ns, range_ns),
      lateness_(resolution_ns, range_ns) {
  if (period_ns <= 0)
    throw std::invalid_argument("cycle stats: period must be > 0 ns (got " +
                                std::to_string(period_ns) + ")");
}

bool CycleStats::record(std::int64_t lateness_ns, std::int64_t cycle_ns,
                        std::int64_t response_ns) noexcept {
  cycle_.add(cycle_ns);
  lateness_.add(lateness_ns);
  const bool missed = response_ns > deadline_;
  if (missed) {
    ++misses_;
    ++consecutive_;
    max_consecutive_ = std::max(max_consecutive_, consecutive_);
  } else {
    consecutive_ = 0;
  }
  return missed;
}

void CycleStats::reset() noexcept {
  cycle_.reset();
  lateness_.reset();
  misses_ = overruns_ = 0;
  consecutive_ = max_consecutive_ = 0;
}

LoopStatsSummary CycleStats::summary() const noexcept {
  LoopStatsSummary s;
  s.period_ns = period_;
  s.deadline_ns = deadline_;
  s.resolution_ns = cycle_.resolution_ns();
  s.cycles = cycle_.count();
  s.cycle = cycle_.summary();
  s.lateness = lateness_.summary();
  s.deadline_misses = misses_;
  s.overruns = overruns_;
  s.consecutive_misses = consecutive_;
  s.max_consecutive_misses = max_consecutive_;
  return s;
}

}  // namespace dualv::control
