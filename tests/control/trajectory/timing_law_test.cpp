// control/trajectory/timing_law.hpp: eq. 9 (original clock), eq. 16 (retiming) and the C3 variant.
#include "control/trajectory/timing_law.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace dualv::trajectory {
namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;

TimingLaw law(TimingKind k, double T = 0.5, double tau = 0.1, double l0 = 0.0, double lf = kTwoPi) {
  return TimingLaw{k, T, tau, l0, lf};
}

// eq. 16 typed in independently, t from the segment start.
double paper_eq16(double t, double T, double tau, double l0, double lf) {
  const double k = (lf - l0) / (2 * tau * tau * tau * (T - tau));
  if (t <= tau) return k * (-std::pow(t, 4) + 2 * tau * std::pow(t, 3)) + l0;
  if (t <= T - tau) return (lf - l0) / (T - tau) * (t - tau / 2) + l0;
  return k * (std::pow(t - T, 4) + 2 * tau * std::pow(t - T, 3)) + lf;
}

double jump(const PhaseSample& a, const PhaseSample& b, int order) {
  const double va[4] = {a.lambda, a.lambda_dot, a.lambda_dd, a.lambda_ddd};
  const double vb[4] = {b.lambda, b.lambda_dot, b.lambda_dd, b.lambda_ddd};
  return std::abs(va[order] - vb[order]);
}

TEST(TimingLaw, ValidateRejectsBadDurationsAndBlends) {
  EXPECT_EQ(law(TimingKind::kRetimed).validate(), "");
  EXPECT_NE(law(TimingKind::kRetimed, 0.0).validate().find("T must be > 0"), std::string::npos);
  EXPECT_NE(law(TimingKind::kRetimed, -1.0).validate().find("T must be > 0"), std::string::npos);
  EXPECT_NE(law(TimingKind::kRetimed, 0.5, 0.0).validate().find("tau"), std::string::npos);
  EXPECT_NE(law(TimingKind::kRetimed, 0.5, 0.25).validate().find("tau"), std::string::npos);
  EXPECT_NE(law(TimingKind::kSmooth, 0.5, 0.3).validate().find("tau"), std::string::npos);
  EXPECT_NE(law(TimingKind::kRetimed, 0.5, NAN).validate().find("tau"), std::string::npos);
  EXPECT_EQ(law(TimingKind::kOriginal, 0.5, 0.0).validate(), "");  // no blend
  EXPECT_NE(law(TimingKind::kOriginal, 0.5, 0.1, NAN).validate(), "");
}

TEST(TimingLaw, RetimedMatchesThePapersEquation16) {
  for (double T : {0.5, 1.0, 2.3})
    for (double tau : {0.01, 0.1 * T, 0.3 * T, 0.499 * T})
      for (double t = 0; t <= T; t += T / 997) {
        const TimingLaw l = law(TimingKind::kRetimed, T, tau, 0.3, 0.3 + kTwoPi);
        EXPECT_NEAR(l.sample(t).lambda, paper_eq16(t, T, tau, 0.3, 0.3 + kTwoPi), 1e-12)
            << "T " << T << " tau " << tau << " t " << t;
      }
}

TEST(TimingLaw, BlendedLawsStartAndEndAtRest) {
  for (auto k : {TimingKind::kRetimed, TimingKind::kSmooth}) {
    const TimingLaw l = law(k, 0.5, 0.1, 1.0, 1.0 + kTwoPi);
    for (double t : {0.0, 0.5, -1.0, 2.0}) {
      const PhaseSample s = l.sample(t);
      EXPECT_EQ(s.lambda, t < 0.25 ? 1.0 : 1.0 + kTwoPi) << to_string(k) << " t " << t;
      EXPECT_NEAR(s.lambda_dot, 0.0, 1e-12) << to_string(k) << " t " << t;
      EXPECT_NEAR(s.lambda_dd, 0.0, 1e-9) << to_string(k) << " t " << t;
    }
  }
  // The C3 law also starts and ends with zero jerk; eq. 16 does not (C2 only).
  EXPECT_NEAR(law(TimingKind::kSmooth).sample(0.0).lambda_ddd, 0.0, 1e-9);
  EXPECT_NEAR(law(TimingKind::kSmooth).sample(0.5).lambda_ddd, 0.0, 1e-9);
  EXPECT_GT(std::abs(law(TimingKind::kRetimed).sample(0.0).lambda_ddd), 1.0);
}

TEST(TimingLaw, BlendedLawsAreContinuousAtTheBlendJoints) {
  for (auto k : {TimingKind::kRetimed, TimingKind::kSmooth}) {
    const TimingLaw l = law(k, 0.5, 0.1);
    for (double tj : {0.1, 0.4}) {
      const PhaseSample a = l.sample(std::nextafter(tj, 0.0));
      const PhaseSample b = l.sample(std::nextafter(tj, 1.0));
      for (int order = 0; order < 3; ++order)
        EXPECT_LT(jump(a, b, order), 1e-9) << to_string(k) << " t " << tj << " order " << order;
      if (k == TimingKind::kSmooth) {
        EXPECT_LT(jump(a, b, 3), 1e-6) << "C3 at " << tj;
      } else {
        EXPECT_GT(jump(a, b, 3), 1.0) << "eq. 16 jerk step at " << tj;
      }
    }
  }
}

TEST(TimingLaw, OriginalClockJumpsAtTheEnds) {
  // eq. 9: lambda_dot steps from 0 to 2 pi / T at t = 0 and back at t = T (eq. 7-8).
  const TimingLaw l = law(TimingKind::kOriginal, 0.5);
  EXPECT_NEAR(l.sample(0.0).lambda_dot, kTwoPi / 0.5, 1e-12);
  EXPECT_EQ(l.sample(-1e-12).lambda_dot, 0.0);
  EXPECT_NEAR(l.sample(0.5).lambda_dot, kTwoPi / 0.5, 1e-12);
  EXPECT_EQ(l.sample(0.5 + 1e-12).lambda_dot, 0.0);
  EXPECT_NEAR(l.sample(0.25).lambda, std::numbers::pi, 1e-12);
}

TEST(TimingLaw, CruiseSpeedAndMonotonicity) {
  for (auto k : {TimingKind::kRetimed, TimingKind::kSmooth}) {
    const TimingLaw l = law(k, 0.5, 0.1);
    EXPECT_NEAR(l.cruise_speed(), kTwoPi / 0.4, 1e-12);
    EXPECT_NEAR(l.sample(0.25).lambda_dot, l.cruise_speed(), 1e-12);
    double prev = -1;
    for (double t = 0; t <= 0.5; t += 1e-4) {
      const PhaseSample s = l.sample(t);
      EXPECT_GE(s.lambda_dot, -1e-12);
      EXPECT_LE(s.lambda_dot, l.cruise_speed() + 1e-9);
      EXPECT_GE(s.lambda, prev);
      prev = s.lambda;
    }
  }
  EXPECT_NEAR(law(TimingKind::kOriginal).cruise_speed(), kTwoPi / 0.5, 1e-12);
}

TEST(TimingLaw, PeakPhaseAccelerationOfEachBlend) {
  // eq. 16: max lambda_dd = 1.5 V / tau at t = tau/2; C3 variant: 1.875 V / tau.
  const double V = kTwoPi / 0.4;
  EXPECT_NEAR(law(TimingKind::kRetimed).sample(0.05).lambda_dd, 1.5 * V / 0.1, 1e-9);
  EXPECT_NEAR(law(TimingKind::kSmooth).sample(0.05).lambda_dd, 1.875 * V / 0.1, 1e-9);
}

TEST(TimingLaw, DerivativesMatchFiniteDifferences) {
  std::mt19937 rng(16);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double h = 1e-6;
  for (auto k : {TimingKind::kOriginal, TimingKind::kRetimed, TimingKind::kSmooth}) {
    for (int trial = 0; trial < 50; ++trial) {
      const double T = 0.2 + 2 * u(rng);
      const double tau = (0.01 + 0.48 * u(rng)) * T;
      const double l0 = -3 + 6 * u(rng);
      const double lf = l0 + (u(rng) < 0.5 ? -1 : 1) * (0.5 + 10 * u(rng));
      const TimingLaw l = law(k, T, tau, l0, lf);
      for (int i = 0; i < 40; ++i) {
        const double t = 2 * h + (T - 4 * h) * u(rng);
        if (std::abs(t - tau) < 4 * h || std::abs(t - (T - tau)) < 4 * h) continue;  // joints
        const PhaseSample s = l.sample(t), p = l.sample(t + h), m = l.sample(t - h);
        const double scale = 1 + std::abs(s.lambda_ddd) + std::abs(s.lambda_dd);
        EXPECT_NEAR(s.lambda_dot, (p.lambda - m.lambda) / (2 * h), 1e-5 * scale);
        EXPECT_NEAR(s.lambda_dd, (p.lambda_dot - m.lambda_dot) / (2 * h), 1e-5 * scale);
        EXPECT_NEAR(s.lambda_ddd, (p.lambda_dd - m.lambda_dd) / (2 * h), 1e-4 * scale);
      }
    }
  }
}

TEST(TimingLaw, NanTimeRestsAtStart) {
  const PhaseSample s = law(TimingKind::kRetimed).sample(NAN);
  EXPECT_EQ(s.lambda, 0.0);
  EXPECT_EQ(s.lambda_dot, 0.0);
}

TEST(TimingLaw, ParsesNames) {
  TimingKind k{};
  for (auto want : {TimingKind::kOriginal, TimingKind::kRetimed, TimingKind::kSmooth}) {
    ASSERT_TRUE(parse_timing_kind(to_string(want), k));
    EXPECT_EQ(k, want);
  }
  EXPECT_FALSE(parse_timing_kind("affine", k));
}

}  // namespace
}  // namespace dualv::trajectory
