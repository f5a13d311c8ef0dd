// control/trajectory/streaming_reference.hpp: a setpoint jump becomes a smooth, limited motion.
// The bounds checked here come from the configured limits (and the finite differences of the
// samples), never from the generator's own internals.
#include "control/trajectory/streaming_reference.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "control/model/kinematics.hpp"
#include "test_util.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::trajectory {
namespace {

using test::dualv_model;
using test::kHome;

constexpr double kPeriod = 1e-3;

StreamingLimits limits() {
  StreamingLimits l;
  l.max_speed = 0.1;
  l.max_acceleration = 1.0;
  l.max_angular_speed = 0.5;
  l.max_angular_acceleration = 5.0;
  return l;
}

Workspace box() {
  Workspace w;
  w.x = {-0.10, 0.10};
  w.y = {0.15, 0.35};
  w.theta = {-0.35, 0.35};
  return w;
}

// What a run of the generator produced, cycle by cycle.
struct Trace {
  std::vector<CartesianSample> s;
};

Trace run(StreamingReference& ref, int cycles) {
  Trace tr;
  Reference out;
  for (int k = 0; k < cycles; ++k) {
    EXPECT_EQ(ref.step(true, out), SampleStatus::kOk) << k;
    tr.s.push_back(out.cartesian);
  }
  return tr;
}

// Every sample within the limits, and consecutive samples consistent with them: X moves at
// most v h, X_dot at most a h, X_dd at most j h per cycle (j: the largest jerk a
// critically-damped third-order follower within (v, a) can produce, 2.12 a^2 / v).
void expect_within_limits(const Trace& tr, const StreamingLimits& l, const Pose& start) {
  const double tol = 1 + 1e-9;
  const double j_xy = 2.117 * l.max_acceleration * l.max_acceleration / l.max_speed;
  const double j_th =
      2.117 * l.max_angular_acceleration * l.max_angular_acceleration / l.max_angular_speed;
  CartesianSample prev;
  prev.X = start;
  for (std::size_t k = 0; k < tr.s.size(); ++k) {
    const CartesianSample& c = tr.s[k];
    ASSERT_TRUE(c.X.allFinite() && c.X_dot.allFinite() && c.X_dd.allFinite()) << k;
    ASSERT_LE(c.X_dot.head<2>().norm(), l.max_speed * tol) << k;
    ASSERT_LE(std::abs(c.X_dot[2]), l.max_angular_speed * tol) << k;
    ASSERT_LE(c.X_dd.head<2>().norm(), l.max_acceleration * tol) << k;
    ASSERT_LE(std::abs(c.X_dd[2]), l.max_angular_acceleration * tol) << k;
    ASSERT_LE((c.X - prev.X).head<2>().norm(), l.max_speed * kPeriod * tol) << k;
    ASSERT_LE((c.X_dot - prev.X_dot).head<2>().norm(), l.max_acceleration * kPeriod * tol) << k;
    ASSERT_LE((c.X_dd - prev.X_dd).head<2>().norm(), j_xy * kPeriod * tol) << k;
    ASSERT_LE(std::abs(c.X_dd[2] - prev.X_dd[2]), j_th * kPeriod * tol) << k;
    prev = c;
  }
}

TEST(StreamingReference, AtRestAtTheActualPoseUntilATargetArrives) {
  StreamingReference ref(dualv_model(), limits(), box(), kPeriod);
  const Pose actual(0.01, 0.24, 0.02);
  ref.reset(actual);
  const Trace tr = run(ref, 200);
  for (const auto& c : tr.s) {
    ASSERT_LT((c.X - actual).cwiseAbs().maxCoeff(), 1e-12);
    ASSERT_LT(c.X_dot.cwiseAbs().maxCoeff(), 1e-12);
    ASSERT_LT(c.X_dd.cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(StreamingReference, AStepBecomesABoundedContinuousMotionThatConverges) {
  const StreamingLimits l = limits();
  StreamingReference ref(dualv_model(), l, box(), kPeriod);
  ref.reset(kHome);
  const Pose target = kHome + Pose(0.08, -0.05, 0.3);
  ASSERT_EQ(ref.set_target(target), TargetStatus::kAccepted);
  // Distance 94 mm at 0.1 m/s, 0.3 rad at 0.5 rad/s: about 1 s plus the follower's lag.
  const Trace tr = run(ref, 3000);
  expect_within_limits(tr, l, kHome);
  // The first cycle after the jump: the plate has barely started (no step in X, X_dot, X_dd).
  EXPECT_LT((tr.s[0].X - kHome).norm(), 1e-6);
  EXPECT_LT(tr.s[0].X_dot.norm(), 1e-3);
  EXPECT_LT(tr.s[0].X_dd.head<2>().norm(), 0.05 * l.max_acceleration);
  // X_dot is the derivative of X (trapezoid rule on the samples).
  for (std::size_t k = 1; k < tr.s.size(); ++k) {
    const Twist fd = (tr.s[k].X - tr.s[k - 1].X) / kPeriod;
    const Twist mid = 0.5 * (tr.s[k].X_dot + tr.s[k - 1].X_dot);
    ASSERT_LT((fd - mid).cwiseAbs().maxCoeff(), 1e-5) << k;
  }
  // Monotone: never beyond the target on any axis (no overshoot), and there at the end.
  for (const auto& c : tr.s) {
    ASSERT_LE(c.X[0], target[0] + 1e-12);
    ASSERT_GE(c.X[1], target[1] - 1e-12);
    ASSERT_LE(c.X[2], target[2] + 1e-12);
  }
  EXPECT_LT((tr.s.back().X - target).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT(tr.s.back().X_dot.cwiseAbs().maxCoeff(), 1e-5);
  // The limits are used, not only respected: a long move cruises near the speed limit.
  double peak = 0.0;
  for (const auto& c : tr.s) peak = std::max(peak, c.X_dot.head<2>().norm());
  EXPECT_GT(peak, 0.9 * l.max_speed);
}

TEST(StreamingReference, JointReferencesAreTheIkOfXd) {
  const model::Model& m = dualv_model();
  StreamingReference ref(m, limits(), box(), kPeriod);
  ref.reset(kHome);
  ASSERT_EQ(ref.set_target(kHome + Pose(0.03, 0.02, 0.1)), TargetStatus::kAccepted);
  Reference out;
  model::Data data(m);
  for (int k = 0; k < 500; ++k) {
    ASSERT_EQ(ref.step(true, out), SampleStatus::kOk);
    ASSERT_EQ(model::update_kinematics(m, data, out.cartesian.X, out.cartesian.X_dot),
              model::Status::kOk);
    ASSERT_LT((out.q - data.q).cwiseAbs().maxCoeff(), 1e-12);
    ASSERT_LT((out.q_dot - data.q_dot).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(StreamingReference, NonFiniteAndOutsideSetpointsAreRefusedAndNeverMoveXd) {
  const Pose good = kHome + Pose(0.02, 0.01, 0.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const Pose bad[] = {Pose(nan, 0.25, 0.0),   Pose(0.0, inf, 0.0),  Pose(0.0, 0.25, -nan),
                      Pose(0.11, 0.25, 0.0),  Pose(0.0, 0.14, 0.0), Pose(0.0, 0.25, 0.36),
                      Pose(-1e300, 0.25, 0.0)};
  StreamingReference clean(dualv_model(), limits(), box(), kPeriod);
  StreamingReference hit(dualv_model(), limits(), box(), kPeriod);
  clean.reset(kHome);
  hit.reset(kHome);
  ASSERT_EQ(clean.set_target(good), TargetStatus::kAccepted);
  ASSERT_EQ(hit.set_target(good), TargetStatus::kAccepted);
  Reference a, b;
  int refused_nf = 0, refused_ws = 0;
  for (int k = 0; k < 1500; ++k) {
    const Pose& p = bad[k % std::size(bad)];
    const TargetStatus s = hit.set_target(p);
    ASSERT_NE(s, TargetStatus::kAccepted) << p.transpose();
    (s == TargetStatus::kNonFinite ? refused_nf : refused_ws)++;
    ASSERT_EQ(clean.step(true, a), SampleStatus::kOk);
    ASSERT_EQ(hit.step(true, b), SampleStatus::kOk);
    ASSERT_EQ(a.cartesian.X, b.cartesian.X) << k;  // bit for bit: refused = never seen
    ASSERT_EQ(a.cartesian.X_dd, b.cartesian.X_dd) << k;
  }
  EXPECT_EQ(hit.target(), good);
  EXPECT_EQ(hit.refused(TargetStatus::kNonFinite), static_cast<std::uint64_t>(refused_nf));
  EXPECT_EQ(hit.refused(TargetStatus::kOutsideWorkspace), static_cast<std::uint64_t>(refused_ws));
  EXPECT_GT(refused_nf, 0);
  EXPECT_GT(refused_ws, 0);
  EXPECT_EQ(hit.accepted(), 1u);
}

TEST(StreamingReference, RandomJumpingSetpointsStayInsideTheWorkspaceAndTheLimits) {
  const StreamingLimits l = limits();
  const Workspace w = box();
  StreamingReference ref(dualv_model(), l, w, kPeriod);
  ref.reset(kHome);
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> ux(w.x.lo, w.x.hi), uy(w.y.lo, w.y.hi),
      ut(w.theta.lo, w.theta.hi);
  std::uniform_int_distribution<int> hold_for(1, 400);
  // Corners often: the hardest targets for a follower that might overshoot.
  std::bernoulli_distribution corner(0.5);
  Trace tr;
  Reference out;
  for (int k = 0; k < 20000;) {
    Pose p(ux(rng), uy(rng), ut(rng));
    if (corner(rng))
      p = Pose(p[0] > 0 ? w.x.hi : w.x.lo, p[1] > 0.25 ? w.y.hi : w.y.lo,
               p[2] > 0 ? w.theta.hi : w.theta.lo);
    ASSERT_EQ(ref.set_target(p), TargetStatus::kAccepted);
    for (int n = hold_for(rng); n > 0; --n, ++k) {
      ref.step(true, out);
      tr.s.push_back(out.cartesian);
    }
  }
  expect_within_limits(tr, l, kHome);
  for (const auto& c : tr.s) {
    ASSERT_TRUE(w.x.contains(c.X[0]) && w.y.contains(c.X[1]) && w.theta.contains(c.X[2]))
        << c.X.transpose();
  }
}

TEST(StreamingReference, HoldStopsSmoothlyAndRefusesLaterSetpoints) {
  const StreamingLimits l = limits();
  StreamingReference ref(dualv_model(), l, box(), kPeriod);
  ref.reset(kHome);
  ASSERT_EQ(ref.set_target(kHome + Pose(0.09, 0.0, 0.0)), TargetStatus::kAccepted);
  Trace tr = run(ref, 400);  // mid-move, cruising
  ASSERT_GT(tr.s.back().X_dot[0], 0.5 * l.max_speed);
  const double x_at_hold = tr.s.back().X[0];
  ref.hold();
  EXPECT_FALSE(ref.active());
  EXPECT_EQ(ref.set_target(kHome), TargetStatus::kNotActive);
  const Trace after = run(ref, 2000);
  Trace all = tr;
  all.s.insert(all.s.end(), after.s.begin(), after.s.end());
  expect_within_limits(all, l, kHome);
  // Stops within the braking distance the limits allow (plus the follower's lag), at rest.
  const double x_end = after.s.back().X[0];
  EXPECT_GT(x_end, x_at_hold);
  EXPECT_LT(x_end - x_at_hold, 0.02);
  EXPECT_LT(after.s.back().X_dot.norm(), 1e-6);
  EXPECT_LT(x_end, kHome[0] + 0.06);  // it stopped: the old target (0.09) is not reached
}

TEST(StreamingReference, NotAdvancingHoldsTheReference) {
  StreamingReference ref(dualv_model(), limits(), box(), kPeriod);
  ref.reset(kHome);
  ASSERT_EQ(ref.set_target(kHome + Pose(0.05, 0.0, 0.0)), TargetStatus::kAccepted);
  Reference out;
  for (int k = 0; k < 100; ++k) ref.step(false, out);
  EXPECT_EQ(out.cartesian.X, kHome);
  EXPECT_EQ(ref.time(), 0.0);
}

TEST(StreamingReference, BadLimitsAreRefusedAtSetUp) {
  StreamingLimits l = limits();
  l.max_acceleration = 0.0;
  EXPECT_THROW(StreamingReference(dualv_model(), l, box(), kPeriod), std::invalid_argument);
  l = limits();
  l.max_angular_speed = std::nan("");
  EXPECT_THROW(StreamingReference(dualv_model(), l, box(), kPeriod), std::invalid_argument);
  EXPECT_THROW(StreamingReference(dualv_model(), limits(), box(), 0.0), std::invalid_argument);
}

TEST(StreamingReference, StepAndSetTargetAllocateNothing) {
  StreamingReference ref(dualv_model(), limits(), box(), kPeriod);
  ref.reset(kHome);
  Reference out;
  ref.step(true, out);  // the Reference's joint vectors get their size once
  const long before = dualv::test::allocation_count();
  for (int k = 0; k < 2000; ++k) {
    ref.set_target(kHome + Pose(k % 2 ? 0.05 : -0.05, 0.0, std::nan("")));
    ref.set_target(kHome + Pose(k % 2 ? 0.05 : -0.05, 0.0, 0.0));
    ref.step(true, out);
  }
  ref.hold();
  ref.step(true, out);
  EXPECT_EQ(dualv::test::allocation_count() - before, 0);
}

}  // namespace
}  // namespace dualv::trajectory
