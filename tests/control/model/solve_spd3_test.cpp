#include "control/model/solve_spd3.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

namespace dualv::model {
namespace {

// Random SPD matrices Q diag(lambda) Q^T with eigenvalues spread over `decades` decades, so the
// condition number is known: 10^decades.
Eigen::Matrix3d random_spd(std::mt19937_64& rng, double decades) {
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Matrix3d A;
  for (int i = 0; i < 9; ++i) A(i / 3, i % 3) = g(rng);
  const Eigen::Matrix3d Q = Eigen::HouseholderQR<Eigen::Matrix3d>(A).householderQ();
  const Eigen::Vector3d lambda(1.0, std::pow(10.0, -decades / 2.0), std::pow(10.0, -decades));
  return Q * lambda.asDiagonal() * Q.transpose();
}

TEST(SolveSpd3, RecoversAKnownSolutionToRoundOffTimesTheCondition) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  for (double decades : {0.0, 2.0, 4.0, 6.0}) {
    for (int trial = 0; trial < 200; ++trial) {
      const Eigen::Matrix3d M = random_spd(rng, decades);
      const Eigen::Vector3d x(g(rng), g(rng), g(rng));
      const Eigen::Vector3d b = M * x;
      const double tol = 1e-13 * std::pow(10.0, decades) * x.norm();  // ~450 eps * condition
      Eigen::Vector3d y;
      ASSERT_TRUE(solve_spd3(M, b, y));
      EXPECT_LT((y - x).norm(), tol) << "condition 1e" << decades;
      Ldlt3 ldlt;
      ASSERT_TRUE(ldlt.factor(M));
      ldlt.solve(b, y);
      EXPECT_LT((y - x).norm(), tol) << "condition 1e" << decades;
      EXPECT_LT((ldlt.inverse() * M - Eigen::Matrix3d::Identity()).norm(),
                1e-13 * std::pow(10.0, decades));
    }
  }
}

TEST(SolveSpd3, RefusesMatricesThatAreNotPositiveDefinite) {
  Eigen::Vector3d y;
  const Eigen::Vector3d b(1.0, 2.0, 3.0);
  Eigen::Matrix3d indefinite = Eigen::Vector3d(1.0, -1.0, 2.0).asDiagonal();
  EXPECT_FALSE(solve_spd3(indefinite, b, y));
  EXPECT_FALSE(solve_spd3(Eigen::Matrix3d::Zero(), b, y));
  const Eigen::Vector3d v(1.0, 2.0, 3.0);
  EXPECT_FALSE(solve_spd3(v * v.transpose(), b, y));  // rank one: singular
  Eigen::Matrix3d nan = Eigen::Matrix3d::Identity();
  nan(1, 1) = std::nan("");
  EXPECT_FALSE(solve_spd3(nan, b, y));
  Ldlt3 ldlt;
  EXPECT_FALSE(ldlt.factor(indefinite));
  EXPECT_FALSE(ldlt.factor(nan));
}

TEST(Ldlt3, RelativeToleranceRefusesNearlySingularMatrices) {
  std::mt19937_64 rng(9);
  Ldlt3 ldlt;
  // Condition numbers above 27 / tolerance are always refused, well-conditioned ones pass.
  for (int trial = 0; trial < 100; ++trial) {
    EXPECT_FALSE(ldlt.factor(random_spd(rng, 14.0), 1e-12));
    EXPECT_TRUE(ldlt.factor(random_spd(rng, 6.0), 1e-12));
  }
}

}  // namespace
}  // namespace dualv::model
