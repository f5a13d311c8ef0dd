// control/trajectory/shape.hpp: eq. 4 shapes and their analytic lambda derivatives.
#include "control/trajectory/shape.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "test_util.hpp"

namespace dualv::trajectory {
namespace {

using test::kHome;
using test::max_diff;
constexpr double kPi = std::numbers::pi;
const BuiltinShape kAll[] = {BuiltinShape::kCircle, BuiltinShape::kEllipse, BuiltinShape::kTear,
                             BuiltinShape::kDeltoid};

// Central differences of the analytic lower derivative: each order checked on its own, and the
// third derivative also straight from positions.
void expect_derivatives_match(const Shape& s, double l, double scale) {
  const double h = 1e-5;
  ShapePoint p, pp, pm;
  s.evaluate(l, p);
  s.evaluate(l + h, pp);
  s.evaluate(l - h, pm);
  const double tol = 1e-7 * scale;
  EXPECT_LT(max_diff(p.d1, (pp.p - pm.p) / (2 * h)), tol) << "d1 at lambda " << l;
  EXPECT_LT(max_diff(p.d2, (pp.d1 - pm.d1) / (2 * h)), tol) << "d2 at lambda " << l;
  EXPECT_LT(max_diff(p.d3, (pp.d2 - pm.d2) / (2 * h)), tol) << "d3 at lambda " << l;
  // d3 from positions only: (f(l+2H) - 2 f(l+H) + 2 f(l-H) - f(l-2H)) / (2 H^3).
  // About a zero centre (the centre does not change derivatives) to keep round-off
  // O(eps |f| / H^3) small; truncation is O(H^2 f^(5)): a loose but still failing bound.
  Shape z = s;
  z.set_centre(Pose::Zero());
  const double H = 1e-3;
  const Pose d3 = (z.position(l + 2 * H) - 2 * z.position(l + H) + 2 * z.position(l - H) -
                   z.position(l - 2 * H)) /
                  (2 * H * H * H);
  EXPECT_LT(max_diff(p.d3, d3), 1e-3 * std::max(scale, p.d3.cwiseAbs().maxCoeff()))
      << "d3 from positions at lambda " << l;
}

TEST(Shape, BuiltinsAreClosedOnZeroToTwoPi) {
  for (auto k : kAll) {
    const Shape s = make_builtin_shape(k, kHome);
    EXPECT_LT(max_diff(s.position(0.0), s.position(2 * kPi)), 1e-15) << to_string(k);
  }
}

TEST(Shape, BuiltinsAreSizedLikeThePaper) {
  // About +-20 mm in x and +-15 mm in y about home (section V).
  for (auto k : kAll) {
    const Shape s = make_builtin_shape(k, kHome);
    double xmax = 0, ymax = 0;
    for (int i = 0; i <= 20000; ++i) {
      const Pose p = s.position(2 * kPi * i / 20000.0) - kHome;
      xmax = std::max(xmax, std::abs(p.x()));
      ymax = std::max(ymax, std::abs(p.y()));
      EXPECT_EQ(p.z(), 0.0);
    }
    EXPECT_LE(xmax, 0.020 + 1e-12) << to_string(k);
    EXPECT_GE(xmax, 0.015 - 1e-9) << to_string(k);
    EXPECT_NEAR(ymax, 0.015, 1e-6) << to_string(k);
  }
}

TEST(Shape, TearMatchesItsProductForm) {
  // y = b sin l sin^2(l/2) written in eq. 4 form as (b/2) sin l - (b/4) sin 2l.
  const Shape s = make_builtin_shape(BuiltinShape::kTear, Pose::Zero());
  const double b = 0.015 / (std::sqrt(3.0) / 2 * 0.75);
  for (double l = 0; l < 2 * kPi; l += 0.01) {
    const double s2 = std::sin(l / 2);
    EXPECT_NEAR(s.position(l).y(), b * std::sin(l) * s2 * s2, 1e-15);
    EXPECT_NEAR(s.position(l).x(), 0.020 * std::cos(l), 1e-15);
  }
}

TEST(Shape, DeltoidMatchesItsDefinition) {
  const Shape s = make_builtin_shape(BuiltinShape::kDeltoid, Pose::Zero());
  const double k = 0.015 / (1.5 * std::sqrt(3.0));
  for (double l = 0; l < 2 * kPi; l += 0.01) {
    EXPECT_NEAR(s.position(l).x(), k * (2 * std::cos(l) + std::cos(2 * l)), 1e-15);
    EXPECT_NEAR(s.position(l).y(), k * (2 * std::sin(l) - std::sin(2 * l)), 1e-15);
  }
  // Cusps (zero path speed) at 0, 2pi/3, 4pi/3.
  ShapePoint p;
  for (double l : {0.0, 2 * kPi / 3, 4 * kPi / 3}) {
    s.evaluate(l, p);
    EXPECT_LT(p.d1.norm(), 1e-15) << l;
  }
}

TEST(Shape, CircleAboutCentre) {
  const Pose c(0.01, 0.26, 0.1);
  const Shape s = make_builtin_shape(BuiltinShape::kCircle, c, 2.0);
  for (double l = 0; l < 2 * kPi; l += 0.1) {
    const Pose p = s.position(l);
    EXPECT_NEAR((p - c).head<2>().norm(), 0.030, 1e-15);
    EXPECT_EQ(p.z(), 0.1);
  }
}

TEST(Shape, BuiltinDerivativesMatchFiniteDifferences) {
  for (auto k : kAll) {
    const Shape s = make_builtin_shape(k, kHome);
    for (double l = -1.0; l < 7.5; l += 0.37) expect_derivatives_match(s, l, 0.02);
  }
}

TEST(Shape, HighPowersAndFrequenciesMatchFiniteDifferences) {
  // Every power 0..6, both functions, fractional and negative frequencies; at the zeros of
  // sin and cos too (where C^{p-3} would blow up if it were not multiplied by zero).
  for (int p = 0; p <= 6; ++p) {
    TermList x, y, th;
    x.push({0.01, p, 1.5, 0.0, 1, 1.0});
    y.push({0.0, 1, 1.0, 0.02, p, -2.0});
    th.push({0.1, p, 0.5, 0.05, p, 3.0});
    const Shape s({0.0, 0.25, 0.0}, x, y, th);
    for (double l : {0.0, kPi / 2, kPi / 3, kPi, 1.234, 5.5}) {
      expect_derivatives_match(s, l, 1.0);
      ShapePoint pt;
      s.evaluate(l, pt);
      EXPECT_TRUE(pt.d3.allFinite());
    }
  }
}

TEST(Shape, RandomShapesMatchFiniteDifferences) {
  std::mt19937 rng(20140917);
  std::uniform_real_distribution<double> amp(-0.01, 0.01), freq(-3.0, 3.0), lam(0.0, 2 * kPi);
  std::uniform_int_distribution<int> pw(0, 5), nterms(0, static_cast<int>(kMaxTerms));
  for (int trial = 0; trial < 200; ++trial) {
    TermList c[3];
    for (auto& list : c) {
      const int n = nterms(rng);
      for (int i = 0; i < n; ++i)
        ASSERT_TRUE(list.push({amp(rng), pw(rng), freq(rng), amp(rng), pw(rng), freq(rng)}));
    }
    const Shape s(kHome, c[0], c[1], c[2]);
    for (int i = 0; i < 5; ++i) expect_derivatives_match(s, lam(rng), 0.5);
  }
}

TEST(Shape, TermListHasFixedCapacity) {
  TermList l;
  for (std::size_t i = 0; i < kMaxTerms; ++i) EXPECT_TRUE(l.push({}));
  EXPECT_FALSE(l.push({}));
  EXPECT_EQ(l.size, kMaxTerms);
}

TEST(Shape, ZeroPowerIsConstant) {
  TermList x;
  x.push({0.003, 0, 5.0, 0.004, 0, 7.0});
  const Shape s(Pose::Zero(), x, {}, {});
  ShapePoint p;
  s.evaluate(1.0, p);
  EXPECT_DOUBLE_EQ(p.p.x(), 0.007);
  EXPECT_EQ(p.d1.x(), 0.0);
  EXPECT_EQ(p.d2.x(), 0.0);
  EXPECT_EQ(p.d3.x(), 0.0);
}

TEST(Shape, ParsesBuiltinNames) {
  BuiltinShape k{};
  for (auto b : kAll) {
    ASSERT_TRUE(parse_builtin_shape(to_string(b), k));
    EXPECT_EQ(k, b);
  }
  EXPECT_FALSE(parse_builtin_shape("square", k));
  EXPECT_FALSE(parse_builtin_shape("Circle", k));
}

}  // namespace
}  // namespace dualv::trajectory
