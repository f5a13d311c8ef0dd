#include "control/identification/estimation.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <stdexcept>

namespace dualv::identification {

namespace {

struct ScaledSvd {
  double condition = 1e300;
  Eigen::VectorXd weakest;
};

ScaledSvd scaled_svd(const Eigen::MatrixXd& W) {
  ScaledSvd out;
  const Eigen::VectorXd norms = W.colwise().norm().transpose();
  out.weakest = Eigen::VectorXd::Zero(W.cols());
  for (Eigen::Index j = 0; j < W.cols(); ++j)
    if (!(norms[j] > 0.0)) {
      out.weakest[j] = 1.0;
      return out;
    }
  const Eigen::MatrixXd Wn = W * norms.cwiseInverse().asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Wn, Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  out.condition = s[s.size() - 1] > 0.0 ? s[0] / s[s.size() - 1] : 1e300;
  out.weakest = svd.matrixV().col(s.size() - 1);
  return out;
}

}  // namespace

double scaled_condition(const Eigen::MatrixXd& W) { return scaled_svd(W).condition; }

Estimate weighted_least_squares(const Observations& obs) {
  const Eigen::Index N = obs.samples(), r = obs.W.cols();
  if (obs.W.rows() != 3 * N || obs.y.size() != 3 * N)
    throw std::invalid_argument(fmt::format(
        "weighted least squares: {} regressor rows and {} torques for {} samples (need 3 each)",
        obs.W.rows(), obs.y.size(), N));
  if (3 * N <= r)
    throw std::invalid_argument(
        fmt::format("weighted least squares: {} equations for {} unknowns", 3 * N, r));
  // Whitening: L_k^-1 with L_k L_k^T = Jm^T Jm.
  Eigen::MatrixXd Ww(3 * N, r);
  Eigen::VectorXd yw(3 * N);
  for (Eigen::Index k = 0; k < N; ++k) {
    const Eigen::LLT<Eigen::Matrix3d> llt(obs.JmT_Jm[static_cast<std::size_t>(k)]);
    if (llt.info() != Eigen::Success)
      throw std::invalid_argument(fmt::format(
          "weighted least squares: sample {} has a singular Jm^T Jm (a parallel singularity)", k));
    Ww.middleRows(3 * k, 3) = llt.matrixL().solve(obs.W.middleRows(3 * k, 3));
    yw.segment(3 * k, 3) = llt.matrixL().solve(obs.y.segment(3 * k, 3));
  }
  Estimate e;
  e.rows = static_cast<int>(3 * N);
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Ww);
  e.phi = qr.solve(yw);
  const double dof = static_cast<double>(3 * N - r);
  e.torque_noise = std::sqrt((yw - Ww * e.phi).squaredNorm() / dof);
  // (W~^T W~)^-1 through the scaled columns, for accuracy when units differ widely.
  const Eigen::VectorXd norms = Ww.colwise().norm().transpose().cwiseMax(1e-300);
  const Eigen::MatrixXd Wn = Ww * norms.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd info_inv =
      (Wn.transpose() * Wn).ldlt().solve(Eigen::MatrixXd::Identity(r, r));
  e.covariance = e.torque_noise * e.torque_noise * norms.cwiseInverse().asDiagonal() * info_inv *
                 norms.cwiseInverse().asDiagonal();
  e.sigma = e.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  const ScaledSvd s = scaled_svd(Ww);
  e.condition = s.condition;
  e.weakest_direction = s.weakest;
  return e;
}

}  // namespace dualv::identification
