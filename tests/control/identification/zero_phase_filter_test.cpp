// The zero-phase Butterworth low-pass and the central differences against closed forms.
#include "control/identification/zero_phase_filter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace dualv::identification {
namespace {

constexpr double kFs = 1000.0;

std::vector<double> sine(double f, int n, double phase = 0.3) {
  std::vector<double> x(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k)
    x[static_cast<std::size_t>(k)] = std::sin(2 * std::numbers::pi * f * k / kFs + phase);
  return x;
}

TEST(ZeroPhaseLowPass, SineInTheInteriorIsScaledByTheSquaredButterworthGainWithoutPhase) {
  for (int order : {2, 4, 6}) {
    const double fc = 25.0;
    const ZeroPhaseLowPass lp(order, fc, kFs);
    for (double f : {2.0, 10.0, 25.0, 40.0}) {
      // Closed form of the bilinear-transformed Butterworth, applied twice.
      const double r = std::tan(std::numbers::pi * f / kFs) / std::tan(std::numbers::pi * fc / kFs);
      const double expected_gain = 1.0 / (1.0 + std::pow(r, 2.0 * order));
      const int n = 6000;
      const std::vector<double> x = sine(f, n);
      const std::vector<double> y = lp.apply(x);
      for (int k = 2000; k < 4000; k += 7)
        ASSERT_NEAR(y[static_cast<std::size_t>(k)], expected_gain * x[static_cast<std::size_t>(k)],
                    1e-7)
            << "order " << order << " f " << f << " k " << k;
    }
  }
}

TEST(ZeroPhaseLowPass, PassesConstantsAndRampsUnchangedToTheLastSample) {
  const ZeroPhaseLowPass lp(4, 20.0, kFs);
  std::vector<double> x(500);
  for (std::size_t k = 0; k < x.size(); ++k) x[k] = 0.7 - 0.003 * static_cast<double>(k);
  const std::vector<double> y = lp.apply(x);
  for (std::size_t k = 0; k < x.size(); ++k) ASSERT_NEAR(y[k], x[k], 1e-9) << k;
}

TEST(ZeroPhaseLowPass, RefusesBadOrdersAndCutoffs) {
  EXPECT_THROW(ZeroPhaseLowPass(3, 20.0, kFs), std::invalid_argument);
  EXPECT_THROW(ZeroPhaseLowPass(4, 600.0, kFs), std::invalid_argument);
  EXPECT_THROW(ZeroPhaseLowPass(4, 0.0, kFs), std::invalid_argument);
}

TEST(CentralDifference, OfASineIsTheClosedFormOfTheDifferenceQuotient) {
  const double f = 7.0, h = 1.0 / kFs, w = 2 * std::numbers::pi * f;
  const std::vector<double> x = sine(f, 400, 0.0);
  const std::vector<double> d = central_difference(x, h);
  for (int k = 1; k < 399; ++k)
    ASSERT_NEAR(d[static_cast<std::size_t>(k)], std::sin(w * h) / h * std::cos(w * k * h), 1e-9);
  // Quadratics are differentiated exactly everywhere, the ends included.
  std::vector<double> q(50);
  for (std::size_t k = 0; k < q.size(); ++k) {
    const double t = static_cast<double>(k) * h;
    q[k] = 3.0 * t * t - 2.0 * t;
  }
  const std::vector<double> dq = central_difference(q, h);
  for (std::size_t k = 0; k < q.size(); ++k)
    ASSERT_NEAR(dq[k], 6.0 * static_cast<double>(k) * h - 2.0, 1e-9) << k;
}

}  // namespace
}  // namespace dualv::identification
