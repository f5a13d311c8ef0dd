#include "control/identification/estimation.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
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
  const bool iv = obs.Z.size() > 0;
  if (iv && (obs.Z.rows() != obs.W.rows() || obs.Z.cols() != r))
    throw std::invalid_argument(
        fmt::format("weighted least squares: instruments {} x {} for a regressor {} x {}",
                    obs.Z.rows(), obs.Z.cols(), obs.W.rows(), r));
  if (!obs.t.empty() && obs.t.size() != static_cast<std::size_t>(N))
    throw std::invalid_argument(
        fmt::format("weighted least squares: {} sample times for {} samples", obs.t.size(), N));
  if (3 * N <= r)
    throw std::invalid_argument(
        fmt::format("weighted least squares: {} equations for {} unknowns", 3 * N, r));
  // Whitening: L_k^-1 with L_k L_k^T = Jm^T Jm.
  Eigen::MatrixXd Ww(3 * N, r), Zw(iv ? 3 * N : 0, r);
  Eigen::VectorXd yw(3 * N);
  for (Eigen::Index k = 0; k < N; ++k) {
    const Eigen::LLT<Eigen::Matrix3d> llt(obs.JmT_Jm[static_cast<std::size_t>(k)]);
    if (llt.info() != Eigen::Success)
      throw std::invalid_argument(fmt::format(
          "weighted least squares: sample {} has a singular Jm^T Jm (a parallel singularity)", k));
    Ww.middleRows(3 * k, 3) = llt.matrixL().solve(obs.W.middleRows(3 * k, 3));
    if (iv) Zw.middleRows(3 * k, 3) = llt.matrixL().solve(obs.Z.middleRows(3 * k, 3));
    yw.segment(3 * k, 3) = llt.matrixL().solve(obs.y.segment(3 * k, 3));
  }
  const Eigen::MatrixXd& Z = iv ? Zw : Ww;
  Estimate e;
  e.rows = static_cast<int>(3 * N);
  e.instrumental = iv;
  // Columns scaled to unit norm, for accuracy when units differ widely: phi = D phi_n.
  const Eigen::VectorXd norms = Ww.colwise().norm().transpose().cwiseMax(1e-300);
  const Eigen::VectorXd zn = Z.colwise().norm().transpose().cwiseMax(1e-300);
  const Eigen::MatrixXd Wn = Ww * norms.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd Zn = Z * zn.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd A = Zn.transpose() * Wn;  // r x r
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(A);
  const Eigen::MatrixXd B = lu.inverse();  // bread (normalised)
  const Eigen::VectorXd phi_n = B * (Zn.transpose() * yw);
  e.phi = norms.cwiseInverse().asDiagonal() * phi_n;
  const Eigen::VectorXd res = yw - Wn * phi_n;
  const double dof = static_cast<double>(3 * N - r);
  e.torque_noise = std::sqrt(res.squaredNorm() / dof);
  // Scores g_k = Zn_k^T e_k, one per sample (its three rows).
  Eigen::MatrixXd g(r, N);
  for (Eigen::Index k = 0; k < N; ++k)
    g.col(k) = Zn.middleRows(3 * k, 3).transpose() * res.segment(3 * k, 3);
  // White residuals: S = sigma^2 Zn^T Zn (the textbook covariance). Correlated ones:
  // Newey-West, S = sum_k g_k g_k^T + sum_{0 < t_j - t_k <= T} w (g_k g_j^T + g_j g_k^T),
  // w = 1 - (t_j - t_k) / (T + dt) (Bartlett), scaled by n / (n - r) like sigma^2.
  const Eigen::MatrixXd white = e.torque_noise * e.torque_noise * (Zn.transpose() * Zn);
  Eigen::MatrixXd S = white;
  if (!obs.t.empty() && obs.correlation_time > 0.0) {
    double dt = 1e300;
    for (std::size_t k = 1; k < obs.t.size(); ++k)
      dt = std::min(dt, obs.t[k] - obs.t[k - 1] > 0.0 ? obs.t[k] - obs.t[k - 1] : 1e300);
    const double T = obs.correlation_time, span = T + (dt < 1e300 ? dt : 0.0);
    Eigen::MatrixXd C = Eigen::MatrixXd::Zero(r, r);  // the lagged terms, one side
    for (Eigen::Index k = 0; k < N; ++k)
      for (Eigen::Index j = k + 1; j < N; ++j) {
        const double lag = obs.t[static_cast<std::size_t>(j)] - obs.t[static_cast<std::size_t>(k)];
        if (lag > T) break;
        C.noalias() += ((1.0 - lag / span) * g.col(k)) * g.col(j).transpose();
      }
    S = g * g.transpose() + C + C.transpose();
    S *= static_cast<double>(3 * N) / dof;
  }
  const Eigen::MatrixXd cov_n = B * S * B.transpose();
  const Eigen::MatrixXd cov_white = B * white * B.transpose();
  e.covariance = norms.cwiseInverse().asDiagonal() * cov_n * norms.cwiseInverse().asDiagonal();
  e.sigma = e.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
  {
    const Eigen::VectorXd a = cov_n.diagonal().cwiseMax(0.0), b = cov_white.diagonal();
    double num = 0.0, den = 0.0;
    for (Eigen::Index j = 0; j < r; ++j)
      if (b[j] > 0.0) {
        num += std::sqrt(a[j] / b[j]);
        den += 1.0;
      }
    e.correlation_factor = den > 0.0 ? num / den : 1.0;
  }
  const ScaledSvd s = scaled_svd(Ww);
  e.condition = s.condition;
  e.weakest_direction = s.weakest;
  return e;
}

}  // namespace dualv::identification
