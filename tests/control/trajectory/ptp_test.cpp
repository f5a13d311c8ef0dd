// control/trajectory/ptp.hpp: 5th-order point-to-point moves and dwells.
#include "control/trajectory/ptp.hpp"

#include <gtest/gtest.h>

#include "test_util.hpp"

namespace dualv::trajectory {
namespace {

using test::max_diff;

const PtpMove kMove{Pose(0.0, 0.25, 0.0), Pose(0.02, 0.24, 0.1), 0.4};

TEST(Ptp, EndsAtRestOnThePoses) {
  CartesianSample s;
  kMove.sample(0.0, s);
  EXPECT_LT(max_diff(s.X, kMove.start), 1e-15);
  EXPECT_EQ(s.X_dot.norm(), 0.0);
  EXPECT_EQ(s.X_dd.norm(), 0.0);
  kMove.sample(0.4, s);
  EXPECT_LT(max_diff(s.X, kMove.end), 1e-15);
  EXPECT_LT(s.X_dot.norm(), 1e-15);
  EXPECT_LT(s.X_dd.norm(), 1e-12);
  kMove.sample(-1.0, s);  // clamped, at rest
  EXPECT_LT(max_diff(s.X, kMove.start), 1e-15);
  EXPECT_EQ(s.X_ddd.norm(), 0.0);
  kMove.sample(5.0, s);
  EXPECT_LT(max_diff(s.X, kMove.end), 1e-15);
  EXPECT_EQ(s.X_dot.norm(), 0.0);
  EXPECT_EQ(s.X_ddd.norm(), 0.0);
}

TEST(Ptp, StaysOnTheStraightLineWithPeakSpeedAtHalfTime) {
  CartesianSample s;
  const Twist d = kMove.end - kMove.start;
  for (double t = 0; t <= 0.4; t += 0.001) {
    kMove.sample(t, s);
    const Twist r = s.X - kMove.start;
    const double u = r.dot(d) / d.squaredNorm();
    EXPECT_LT(max_diff(r, u * d), 1e-15);
    EXPECT_GE(u, -1e-15);
    EXPECT_LE(u, 1 + 1e-15);
  }
  kMove.sample(0.2, s);
  EXPECT_NEAR(s.X_dot.norm(), kQuinticPeakSpeed * d.norm() / 0.4, 1e-12);
}

TEST(Ptp, DerivativesMatchFiniteDifferences) {
  const double h = 1e-6;
  CartesianSample s, p, m;
  for (double t = 0.003; t < 0.4; t += 0.0131) {
    kMove.sample(t, s);
    kMove.sample(t + h, p);
    kMove.sample(t - h, m);
    EXPECT_LT(max_diff(s.X_dot, (p.X - m.X) / (2 * h)), 1e-8);
    EXPECT_LT(max_diff(s.X_dd, (p.X_dot - m.X_dot) / (2 * h)), 1e-7);
    EXPECT_LT(max_diff(s.X_ddd, (p.X_dd - m.X_dd) / (2 * h)), 1e-5);
  }
}

TEST(Ptp, MinDurationMeetsTheLimits) {
  const Pose a(0, 0.25, 0), b(0.03, 0.29, 0.2);  // 50 mm, 0.2 rad
  const double T = ptp_min_duration(a, b, 0.1, 1.0, 0.5, 5.0);
  const PtpMove m{a, b, T};
  double vmax = 0, amax = 0, wmax = 0, wdmax = 0;
  CartesianSample s;
  for (double t = 0; t <= T; t += T / 2000) {
    m.sample(t, s);
    vmax = std::max(vmax, s.X_dot.head<2>().norm());
    amax = std::max(amax, s.X_dd.head<2>().norm());
    wmax = std::max(wmax, std::abs(s.X_dot.z()));
    wdmax = std::max(wdmax, std::abs(s.X_dd.z()));
  }
  EXPECT_LE(vmax, 0.1 + 1e-9);
  EXPECT_LE(amax, 1.0 + 1e-9);
  EXPECT_LE(wmax, 0.5 + 1e-9);
  EXPECT_LE(wdmax, 5.0 + 1e-9);
  // ... and is the shortest: one of them is reached.
  const bool tight =
      vmax > 0.1 - 1e-4 || amax > 1.0 - 1e-3 || wmax > 0.5 - 1e-4 || wdmax > 5.0 - 1e-3;
  EXPECT_TRUE(tight);
  EXPECT_EQ(ptp_min_duration(a, a, 0.1, 1.0, 0.5, 5.0), 0.0);
}

TEST(Dwell, HoldsThePose) {
  const Dwell d{Pose(0.01, 0.2, 0.3), 1.0};
  CartesianSample s;
  s.X_dot.setOnes();
  d.sample(0.5, s);
  EXPECT_EQ(s.X, d.pose);
  EXPECT_EQ(s.X_dot.norm() + s.X_dd.norm() + s.X_ddd.norm(), 0.0);
}

}  // namespace
}  // namespace dualv::trajectory
