// Weighted least squares on synthetic data with a known truth and a known noise.
#include "control/identification/estimation.hpp"

#include <gtest/gtest.h>

#include <random>

namespace dualv::identification {
namespace {

TEST(WeightedLeastSquares, RecoversTheTruthAndItsSigmaMatchesTheSpreadOverManyTrials) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  const int N = 300, r = 4;
  const Eigen::Vector4d truth(1.5, -0.3, 0.02, 7.0);
  const double noise = 0.05;  // motor torque sigma [N m]
  Observations obs;
  obs.W.resize(3 * N, r);
  obs.y.resize(3 * N);
  std::vector<Eigen::Matrix<double, 4, 3>> Jm(N);
  for (int k = 0; k < N; ++k) {
    obs.W.middleRows(3 * k, 3) = Eigen::Matrix<double, 3, 4>::Random();
    Jm[k] = Eigen::Matrix<double, 4, 3>::Random() + Eigen::Matrix<double, 4, 3>::Identity() * 3;
    obs.JmT_Jm.push_back(Jm[k].transpose() * Jm[k]);
  }
  const Eigen::VectorXd clean = obs.W * truth;
  Eigen::MatrixXd estimates(200, r);
  double sigma_mean = 0.0;
  for (int trial = 0; trial < 200; ++trial) {
    for (int k = 0; k < N; ++k) {
      Eigen::Vector4d e;
      for (int i = 0; i < 4; ++i) e[i] = noise * g(rng);
      obs.y.segment<3>(3 * k) = clean.segment<3>(3 * k) + Jm[k].transpose() * e;  // Jm^T tau
    }
    const Estimate est = weighted_least_squares(obs);
    estimates.row(trial) = est.phi.transpose();
    sigma_mean += est.sigma[0] / 200;
    EXPECT_NEAR(est.torque_noise, noise, 0.15 * noise);
  }
  const Eigen::RowVectorXd mean = estimates.colwise().mean();
  EXPECT_LT((mean.transpose() - truth).cwiseAbs().maxCoeff(), 0.01);
  const double spread =
      std::sqrt((estimates.col(0).array() - mean[0]).square().sum() / (estimates.rows() - 1));
  EXPECT_NEAR(sigma_mean, spread, 0.2 * spread);  // reported sigma is the real scatter
}

TEST(WeightedLeastSquares, RefusesTooFewRows) {
  Observations obs;
  obs.W = Eigen::MatrixXd::Random(3, 4);
  obs.y = Eigen::VectorXd::Random(3);
  obs.JmT_Jm.push_back(Eigen::Matrix3d::Identity());
  EXPECT_THROW(weighted_least_squares(obs), std::invalid_argument);
}

}  // namespace
}  // namespace dualv::identification
