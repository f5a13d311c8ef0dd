#pragma once
// How many sampling intervals cover a segment: ceil(T / period) computed without undefined
// behaviour (issue 14, defect 3: `(int)ceil(T / period)` overflowed for T = 1e300 and is
// undefined for NaN and Inf). Used by pre-flight (preflight.cpp) and the load-time workspace
// check (program.cpp).
#include <cmath>
#include <optional>

namespace dualv::trajectory {

// ceil(T / period), at least min_intervals; std::nullopt when T or period is not finite, T < 0,
// period <= 0, or the count would exceed max_intervals (the caller refuses the segment).
inline std::optional<int> sample_intervals(double T, double period, int min_intervals,
                                           int max_intervals) noexcept {
  if (!(std::isfinite(T) && std::isfinite(period) && T >= 0.0 && period > 0.0)) return std::nullopt;
  const double n = std::ceil(T / period);  // finite, >= 0; may be huge
  if (!(n <= static_cast<double>(max_intervals))) return std::nullopt;
  const int count = static_cast<int>(n);  // in [0, max_intervals]: defined
  return count < min_intervals ? min_intervals : count;
}

}  // namespace dualv::trajectory
