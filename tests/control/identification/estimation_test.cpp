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
  const double spread = std::sqrt((estimates.col(0).array() - mean[0]).square().sum() /
                                  static_cast<double>(estimates.rows() - 1));
  EXPECT_NEAR(sigma_mean, spread, 0.2 * spread);  // reported sigma is the real scatter
}

// Errors in the regressor that the "torques" react to, as in a closed loop: y = X phi + v,
// measured W = X + U with v = -kp U phi-like coupling. Least squares on W is biased; with the
// noise-free X as instruments the estimate is the truth within its sigma.
TEST(WeightedLeastSquares, InstrumentsRemoveTheBiasOfNoiseSharedByRegressorAndTorques) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  const int N = 4000, r = 3;
  const Eigen::Vector3d truth(2.0, -1.0, 0.5);
  Observations obs;
  obs.W.resize(3 * N, r);
  obs.Z.resize(3 * N, r);
  obs.y.resize(3 * N);
  for (int k = 0; k < N; ++k) {
    const Eigen::Matrix3d X = Eigen::Matrix3d::Random() * 2.0;
    Eigen::Matrix3d U;
    for (int i = 0; i < 9; ++i) U(i) = 0.3 * g(rng);
    obs.Z.middleRows(3 * k, 3) = X;
    obs.W.middleRows(3 * k, 3) = X + U;
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) v[i] = 0.05 * g(rng);
    obs.y.segment<3>(3 * k) = X * truth + v - 2.0 * U * truth;  // the "controller" reacts to U
    obs.JmT_Jm.push_back(Eigen::Matrix3d::Identity());
  }
  const Estimate iv = weighted_least_squares(obs);
  EXPECT_TRUE(iv.instrumental);
  for (int j = 0; j < r; ++j) EXPECT_LT(std::abs(iv.phi[j] - truth[j]), 3.0 * iv.sigma[j]) << j;
  Observations plain = obs;
  plain.Z.resize(0, 0);
  const Estimate ls = weighted_least_squares(plain);
  EXPECT_FALSE(ls.instrumental);
  EXPECT_GT((ls.phi - truth).cwiseAbs().maxCoeff(), 10.0 * ls.sigma.maxCoeff());
}

// Residuals correlated over m samples (a moving average of white noise, as the zero-phase
// low-pass makes them): the white-noise sigma is too small by about sqrt(m); the Newey-West
// sigma over the correlation time is the real scatter over many trials, whatever the sampling.
TEST(WeightedLeastSquares, WithCorrelatedResidualsTheNeweyWestSigmaIsTheRealScatter) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0.0, 1.0);
  const int N = 600, r = 2, m = 8;
  const double h = 0.004;
  const Eigen::Vector2d truth(1.0, -2.0);
  Observations obs;
  obs.W.resize(3 * N, r);
  obs.y.resize(3 * N);
  for (int k = 0; k < N; ++k) {
    // Slowly varying regressor (a motion), like the excitation's.
    for (int i = 0; i < 3; ++i) {
      obs.W(3 * k + i, 0) = std::sin(0.01 * k + i);
      obs.W(3 * k + i, 1) = std::cos(0.023 * k + 2 * i);
    }
    obs.JmT_Jm.push_back(Eigen::Matrix3d::Identity());
    obs.t.push_back(k * h);
  }
  obs.correlation_time = 3.0 * m * h;
  const Eigen::VectorXd clean = obs.W * truth;
  const int trials = 300;
  Eigen::MatrixXd estimates(trials, r);
  double sigma_mean = 0.0, white_mean = 0.0;
  std::vector<double> white(3 * (N + m));
  for (int trial = 0; trial < trials; ++trial) {
    for (double& w : white) w = g(rng);
    for (int k = 0; k < 3 * N; ++k) {
      // Per row i of sample k: the average of m white values along the samples.
      double e = 0.0;
      const int i = k % 3, s = k / 3;
      for (int j = 0; j < m; ++j) e += white[static_cast<std::size_t>(3 * (s + j) + i)];
      obs.y[k] = clean[k] + 0.1 * e / m;
    }
    Observations o = obs;
    const Estimate est = weighted_least_squares(o);
    o.correlation_time = 0.0;
    const Estimate est_white = weighted_least_squares(o);
    estimates.row(trial) = est.phi.transpose();
    sigma_mean += est.sigma[0] / trials;
    white_mean += est_white.sigma[0] / trials;
  }
  const double mean = estimates.col(0).mean();
  const double spread = std::sqrt((estimates.col(0).array() - mean).square().sum() / (trials - 1));
  EXPECT_NEAR(sigma_mean, spread, 0.25 * spread);
  EXPECT_LT(white_mean, 0.6 * spread);  // the white-noise formula is optimistic here
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
