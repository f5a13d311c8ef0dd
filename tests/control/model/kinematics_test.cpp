#include "control/model/kinematics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "model_fixture.hpp"

namespace dualv::model {
namespace {

using test::dual_v;
using test::random_pose;

// A pose counts as well inside the workspace when IK succeeds and both
// singularity measures are comfortably away from zero.
bool well_conditioned(const Model& m, Data& d, const Pose& X) {
  if (update_kinematics(m, d, X, Twist::Zero()) != Status::kOk) return false;
  const auto s = singularity_measures(m, d);
  return s.parallel > 0.05 && s.min_serial > 0.05;
}

TEST(InverseKinematics, HomeMatchesTheClosedFormOfDesignMd) {
  const Model m = dual_v();
  Data d(m);
  JointVector q;
  ASSERT_EQ(inverse_kinematics(m, d, m.home, q), Status::kOk);
  // Chain 1 by hand: A1 = (-0.35, 0), C1 = (-0.11, 0.25), l1 = l2 = 0.28, s = -1.
  const double dx = 0.24, dy = 0.25, dist = std::hypot(dx, dy);
  const double q1 = std::atan2(dy, dx) - std::acos(dist / (2 * 0.28));
  EXPECT_NEAR(q[0], q1, 1e-15);
  // Every elbow is at crank length from its base and coupler length from its anchor.
  for (int i = 0; i < m.n; ++i) {
    EXPECT_NEAR((d.chain[i].elbow - m.chains[i].base).norm(), 0.28, 1e-14);
    EXPECT_NEAR((d.chain[i].anchor - d.chain[i].elbow).norm(), 0.28, 1e-14);
  }
}

TEST(InverseKinematics, UnreachableAndInvalidPosesReturnAStatus) {
  const Model m = dual_v();
  Data d(m);
  JointVector q;
  EXPECT_EQ(inverse_kinematics(m, d, Pose(0.0, 2.0, 0.0), q), Status::kUnreachable);
  EXPECT_EQ(inverse_kinematics(m, d, Pose(NAN, 0.25, 0.0), q), Status::kInvalidInput);
  EXPECT_EQ(inverse_kinematics(m, d, Pose(0.0, INFINITY, 0.0), q), Status::kInvalidInput);
}

TEST(Jacobian, SingularValuesAtHomeMatchDesignMd) {
  const Model m = dual_v();
  Data d(m);
  ASSERT_EQ(update_kinematics(m, d, m.home, Twist::Zero()), Status::kOk);
  const Eigen::Vector3d sv = jacobian_singular_values(d);
  EXPECT_NEAR(sv[0], 7.28, 0.005);
  EXPECT_NEAR(sv[1], 1.01, 0.005);
  EXPECT_NEAR(sv[2], 0.80, 0.005);
}

TEST(ForwardKinematics, RoundTripOverTenThousandRandomPoses) {
  const Model m = dual_v();
  Data d(m);
  std::mt19937_64 rng(42);
  std::normal_distribution<double> seed_noise(0.0, 0.005);
  int tested = 0;
  double worst = 0.0;
  while (tested < 10000) {
    const Pose X = random_pose(m, rng);
    if (!well_conditioned(m, d, X)) continue;
    const JointVector q = d.q;
    // Seed as a running controller would: near the true pose (previous cycle).
    const Pose seed = X + Pose(seed_noise(rng), seed_noise(rng), seed_noise(rng));
    Pose X_fk;
    const FkResult r = forward_kinematics(m, d, q, seed, X_fk);
    ASSERT_EQ(r.status, Status::kOk) << "pose " << X.transpose() << " residual " << r.residual;
    const double err = (X_fk - X).cwiseAbs().maxCoeff();
    worst = std::max(worst, err);
    ASSERT_LT(err, 1e-10) << "pose " << X.transpose();
    ++tested;
  }
  RecordProperty("worst_error", std::to_string(worst));
}

TEST(ForwardKinematics, FromHomeSeedAcrossTheCentralWorkspace) {
  const Model m = dual_v();
  Data d(m);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> xy(-0.03, 0.03), th(-0.1, 0.1);
  for (int k = 0; k < 1000; ++k) {
    const Pose X = m.home + Pose(xy(rng), xy(rng), th(rng));
    ASSERT_TRUE(well_conditioned(m, d, X));
    const JointVector q = d.q;
    Pose X_fk;
    ASSERT_EQ(forward_kinematics(m, d, q, m.home, X_fk).status, Status::kOk);
    EXPECT_LT((X_fk - X).cwiseAbs().maxCoeff(), 1e-10);
  }
}

TEST(ForwardKinematics, ImpossibleJointAnglesGiveAStatusNotNaN) {
  const Model m = dual_v();
  Data d(m);
  JointVector q(m.n);
  q << 1.0, -2.0, 0.3, 2.5;  // chains pulling the plate apart: no pose satisfies all four
  Pose X;
  const FkResult r = forward_kinematics(m, d, q, m.home, X);
  EXPECT_NE(r.status, Status::kOk);
  EXPECT_TRUE(X.allFinite());
  EXPECT_EQ(X, m.home);  // left at the seed
  // Quantised encoders disagree slightly: the least-squares pose is still found.
  ASSERT_EQ(inverse_kinematics(m, d, m.home + Pose(0.01, 0.005, 0.02), q), Status::kOk);
  const Pose truth = m.home + Pose(0.01, 0.005, 0.02);
  const double count = 2 * M_PI / (1 << 20);
  for (int i = 0; i < m.n; ++i) q[i] = std::round(q[i] / count) * count;
  const FkResult lsq = forward_kinematics(m, d, q, m.home, X);
  EXPECT_EQ(lsq.status, Status::kOk);
  EXPECT_GT(lsq.residual, 0.0);
  EXPECT_LT(lsq.residual, 2 * count);
  EXPECT_LT((X - truth).head<2>().norm(), 1e-5);
  q[0] = NAN;
  EXPECT_EQ(forward_kinematics(m, d, q, m.home, X).status, Status::kInvalidInput);
}

TEST(Jacobian, JmMatchesCentralDifferencesOfIk) {
  const Model m = dual_v();
  Data d(m), d2(m);
  std::mt19937_64 rng(1);
  const double h = 1e-6;
  for (int k = 0; k < 500; ++k) {
    const Pose X = random_pose(m, rng);
    if (!well_conditioned(m, d, X)) continue;
    JointJacobian fd(m.n, 3);
    for (int c = 0; c < 3; ++c) {
      JointVector qp, qm;
      ASSERT_EQ(inverse_kinematics(m, d2, X + h * Pose::Unit(c), qp), Status::kOk);
      ASSERT_EQ(inverse_kinematics(m, d2, X - h * Pose::Unit(c), qm), Status::kOk);
      fd.col(c) = (qp - qm) / (2 * h);
    }
    EXPECT_LT((fd - d.Jm).norm() / d.Jm.norm(), 1e-6) << "pose " << X.transpose();
  }
}

TEST(Jacobian, JmDotMatchesCentralDifferencesOfJm) {
  const Model m = dual_v();
  Data d(m), dp(m), dm(m);
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> vel(-0.5, 0.5);
  const double h = 1e-6;
  for (int k = 0; k < 500; ++k) {
    const Pose X = random_pose(m, rng);
    const Twist Xd(vel(rng), vel(rng), 3 * vel(rng));
    if (!well_conditioned(m, d, X)) continue;
    ASSERT_EQ(update_kinematics(m, d, X, Xd), Status::kOk);
    ASSERT_EQ(update_kinematics(m, dp, X + h * Xd, Xd), Status::kOk);
    ASSERT_EQ(update_kinematics(m, dm, X - h * Xd, Xd), Status::kOk);
    const JointJacobian fd = (dp.Jm - dm.Jm) / (2 * h);
    EXPECT_LT((fd - d.Jm_dot).norm() / d.Jm_dot.norm(), 1e-6) << "pose " << X.transpose();
    // And the velocity closure itself: q_dot = Jm X_dot.
    EXPECT_LT((d.q_dot - (dp.q - dm.q) / (2 * h)).norm(), 1e-6 * d.q_dot.norm());
  }
}

TEST(Projectors, RangeProjectorIsASymmetricIdempotentAndNKillsInternalForces) {
  const Model m = dual_v();
  Data d(m);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> tau_dist(0.0, 10.0);
  for (int k = 0; k < 200; ++k) {
    const Pose X = random_pose(m, rng);
    if (!well_conditioned(m, d, X)) continue;
    ASSERT_EQ(update_projectors(m, d), Status::kOk);
    EXPECT_LT((d.R * d.R - d.R).norm(), 1e-12);
    EXPECT_LT((d.R - d.R.transpose()).norm(), 1e-12);
    EXPECT_LT((d.Jm.transpose() * d.N).norm(), 1e-12 * d.Jm.norm());
    EXPECT_NEAR(d.R.trace(), 3.0, 1e-12);  // rank 3 for a 3-dof plate
    JointVector tau(m.n);
    for (int i = 0; i < m.n; ++i) tau[i] = tau_dist(rng);
    const JointVector internal = d.N * tau;
    for (int c = 0; c < 3; ++c)  // orthogonal to every column of Jm
      EXPECT_NEAR(internal.dot(d.Jm.col(c)), 0.0, 1e-10 * tau.norm() * d.Jm.norm());
    // Jm^{T*} solves Jm^T tau = F with minimum norm.
    const Twist F(1.0, -2.0, 0.3);
    const JointVector t = d.JmT_pinv * F;
    EXPECT_LT((d.Jm.transpose() * t - F).norm(), 1e-12);
    EXPECT_LT((d.R * t - t).norm(), 1e-12);  // already in range(Jm)
  }
}

TEST(Singularity, SerialMeasureVanishesWhenCrankAndCouplerAlign) {
  const Model m = dual_v();
  Data d(m);
  // Slide the plate straight away from base 1 until chain 1 is fully stretched.
  const Vec2 A = m.chains[0].base;
  const Vec2 c = m.chains[0].plate_anchor;
  const Vec2 dir = (m.home.head<2>() + c - A).normalized();
  double lo = 0.0, hi = 0.3;  // bisection on the stretch distance
  for (int k = 0; k < 60; ++k) {
    const double mid = 0.5 * (lo + hi);
    const Pose X(m.home.x() + mid * dir.x(), m.home.y() + mid * dir.y(), 0.0);
    JointVector q;
    (inverse_kinematics(m, d, X, q) == Status::kOk ? lo : hi) = mid;
  }
  const Pose near(m.home.x() + lo * dir.x(), m.home.y() + lo * dir.y(), 0.0);
  Data d2(m);
  JointVector q;
  ASSERT_EQ(inverse_kinematics(m, d2, near, q), Status::kOk);
  const double sin_angle = std::abs(d2.chain[0].crank.x() * d2.chain[0].coupler.y() -
                                    d2.chain[0].crank.y() * d2.chain[0].coupler.x()) /
                           (0.28 * 0.28);
  EXPECT_LT(sin_angle, 1e-6);
  const Status s = update_kinematics(m, d2, near, Twist::Zero());
  if (s == Status::kOk) {
    EXPECT_LT(singularity_measures(m, d2).serial[0], 1e-6);
  } else {
    EXPECT_EQ(s, Status::kSerialSingular);
  }
}

}  // namespace
}  // namespace dualv::model
