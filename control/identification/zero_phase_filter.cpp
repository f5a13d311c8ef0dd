#include "control/identification/zero_phase_filter.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace dualv::identification {

ZeroPhaseLowPass::ZeroPhaseLowPass(int order, double cutoff_hz, double sample_hz)
    : order_(order), cutoff_hz_(cutoff_hz), sample_hz_(sample_hz) {
  if (order < 2 || order > 8 || order % 2 != 0)
    throw std::invalid_argument(fmt::format("low-pass order must be 2, 4, 6 or 8 (got {})", order));
  if (!(sample_hz > 0.0) || !(cutoff_hz > 0.0) || !(cutoff_hz < 0.5 * sample_hz))
    throw std::invalid_argument(
        fmt::format("low-pass cutoff must be in (0, {} Hz) (half the sampling rate; got {} Hz)",
                    0.5 * sample_hz, cutoff_hz));
  const double K = std::tan(std::numbers::pi * cutoff_hz / sample_hz);  // prewarped cutoff
  for (int k = 0; k < order / 2; ++k) {
    // Analog pole pair at angle theta_k from the negative real axis: s^2 + s / Q + 1.
    const double theta = std::numbers::pi * (2.0 * k + 1.0) / (2.0 * order);
    const double inv_Q = 2.0 * std::cos(theta);
    const double norm = 1.0 / (1.0 + K * inv_Q + K * K);
    Section s;
    s.b0 = K * K * norm;
    s.b1 = 2.0 * s.b0;
    s.b2 = s.b0;
    s.a1 = 2.0 * (K * K - 1.0) * norm;
    s.a2 = (1.0 - K * inv_Q + K * K) * norm;
    sections_.push_back(s);
  }
  // The slowest section's envelope decays like exp(-2 pi fc sin(theta_0) t): pad for it to
  // fall below 1e-9.
  const double decay =
      2.0 * std::numbers::pi * cutoff_hz * std::sin(std::numbers::pi / (2.0 * order));
  pad_ = static_cast<int>(std::ceil(21.0 / decay * sample_hz));
}

double ZeroPhaseLowPass::gain(double f) const noexcept {
  const double r = std::tan(std::numbers::pi * f / sample_hz_) /
                   std::tan(std::numbers::pi * cutoff_hz_ / sample_hz_);
  return 1.0 / (1.0 + std::pow(r, 2.0 * order_));
}

void ZeroPhaseLowPass::run(std::vector<double>& x) const {
  for (const Section& s : sections_) {
    // Direct form II transposed, started in the steady state of x[0] (unity DC gain).
    double z1 = x[0] * (1.0 - s.b0), z2 = x[0] * (s.b2 - s.a2);
    for (double& v : x) {
      const double in = v;
      const double out = s.b0 * in + z1;
      z1 = s.b1 * in - s.a1 * out + z2;
      z2 = s.b2 * in - s.a2 * out;
      v = out;
    }
  }
}

std::vector<double> ZeroPhaseLowPass::apply(const std::vector<double>& x) const {
  const int n = static_cast<int>(x.size());
  if (n < 2) return x;
  const int pad = std::min(pad_, n - 1);
  // Odd reflection about each end: 2 x[0] - x[pad..1], x, 2 x[n-1] - x[n-2..n-1-pad].
  std::vector<double> y;
  y.reserve(static_cast<std::size_t>(n + 2 * pad));
  for (int k = pad; k >= 1; --k) y.push_back(2.0 * x[0] - x[k]);
  y.insert(y.end(), x.begin(), x.end());
  for (int k = 1; k <= pad; ++k) y.push_back(2.0 * x[n - 1] - x[n - 1 - k]);
  run(y);
  std::reverse(y.begin(), y.end());
  run(y);
  std::reverse(y.begin(), y.end());
  return std::vector<double>(y.begin() + pad, y.begin() + pad + n);
}

std::vector<double> central_difference(const std::vector<double>& x, double h) {
  const std::size_t n = x.size();
  std::vector<double> d(n, 0.0);
  if (n < 3) {
    if (n == 2) d[0] = d[1] = (x[1] - x[0]) / h;
    return d;
  }
  for (std::size_t k = 1; k + 1 < n; ++k) d[k] = (x[k + 1] - x[k - 1]) / (2.0 * h);
  d[0] = (-3.0 * x[0] + 4.0 * x[1] - x[2]) / (2.0 * h);
  d[n - 1] = (3.0 * x[n - 1] - 4.0 * x[n - 2] + x[n - 3]) / (2.0 * h);
  return d;
}

}  // namespace dualv::identification
