#include "control/identification/base_parameters.hpp"

#include <fmt/format.h>

#include <Eigen/QR>
#include <cmath>
#include <random>
#include <stdexcept>

#include "control/identification/regressor.hpp"

namespace dualv::identification {

Eigen::VectorXd BaseParameters::from_standard(const Eigen::VectorXd& phi) const {
  Eigen::VectorXd b(size()), p2(dependent.size());
  for (int j = 0; j < size(); ++j) b[j] = phi[independent[j]];
  for (std::size_t k = 0; k < dependent.size(); ++k) p2[k] = phi[dependent[k]];
  if (!dependent.empty()) b += beta * p2;
  return b;
}

Eigen::MatrixXd BaseParameters::columns(const Eigen::MatrixXd& W) const {
  Eigen::MatrixXd W1(W.rows(), size());
  for (int j = 0; j < size(); ++j) W1.col(j) = W.col(independent[j]);
  return W1;
}

Eigen::VectorXd BaseParameters::to_standard(const Eigen::VectorXd& phi_b,
                                            const Eigen::VectorXd& reference) const {
  Eigen::VectorXd phi = reference;
  Eigen::VectorXd p2(dependent.size());
  for (std::size_t k = 0; k < dependent.size(); ++k) p2[k] = reference[dependent[k]];
  Eigen::VectorXd p1 = phi_b;
  if (!dependent.empty()) p1 -= beta * p2;
  for (int j = 0; j < size(); ++j) phi[independent[j]] = p1[j];
  return phi;
}

bool BaseParameters::has_terms(int j) const {
  return beta.cols() > 0 && (beta.row(j).array() != 0.0).any();
}

std::string BaseParameters::meaning(int j) const {
  std::string s = layout.name(independent[j]);
  for (std::size_t k = 0; k < dependent.size(); ++k) {
    const double c = beta(j, static_cast<Eigen::Index>(k));
    if (c == 0.0) continue;
    s += fmt::format(" {} {:.6g} {}", c < 0 ? '-' : '+', std::abs(c), layout.name(dependent[k]));
  }
  return s;
}

std::vector<int> BaseParameters::inert() const {
  std::vector<int> out;
  for (std::size_t k = 0; k < dependent.size(); ++k)
    if (beta.cols() == 0 || (beta.col(static_cast<Eigen::Index>(k)).array() == 0.0).all())
      out.push_back(dependent[k]);
  return out;
}

BaseParameters find_base_parameters(const model::Model& model, const BaseParameterOptions& o) {
  const ParameterLayout L{model.n};
  const int P = L.size();
  model::Data data(model);
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const auto random3 = [&](const model::Twist& spread) {
    return model::Twist(spread.x() * u(rng), spread.y() * u(rng), spread.z() * u(rng));
  };
  Eigen::MatrixXd W(3 * o.states, P);
  RegressorRows Wk(3, P);
  int rows = 0, tries = 0;
  while (rows < o.states && tries < 20 * o.states) {
    ++tries;
    const model::Pose X = model.home + random3(o.pose_spread);
    if (regressor(model, data, X, random3(o.speed), random3(o.acceleration), Wk) !=
        model::Status::kOk)
      continue;
    W.middleRows(3 * rows, 3) = Wk;
    ++rows;
  }
  if (rows < o.states)
    throw std::runtime_error(fmt::format(
        "base parameters: only {} of {} random poses within ({}, {}, {}) of home are valid "
        "poses of the model (check the model's geometry and home pose)",
        rows, o.states, o.pose_spread.x(), o.pose_spread.y(), o.pose_spread.z()));

  // Columns scaled to unit norm, so that the pivoting and the rank test compare directions,
  // not units. All-zero columns (parameters that never act) are dependent with beta = 0.
  Eigen::VectorXd norms = W.colwise().norm().transpose();
  const double largest = norms.maxCoeff();
  std::vector<int> acting, inert;
  for (int k = 0; k < P; ++k) (norms[k] > 1e-12 * largest ? acting : inert).push_back(k);
  Eigen::MatrixXd Wn(W.rows(), static_cast<Eigen::Index>(acting.size()));
  for (std::size_t k = 0; k < acting.size(); ++k)
    Wn.col(static_cast<Eigen::Index>(k)) = W.col(acting[k]) / norms[acting[k]];

  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Wn);
  qr.setThreshold(o.rank_tolerance);
  const Eigen::MatrixXd R = qr.matrixR().triangularView<Eigen::Upper>();
  int r = 0;
  while (r < R.cols() && std::abs(R(r, r)) > o.rank_tolerance * std::abs(R(0, 0))) ++r;
  const auto perm = qr.colsPermutation().indices();

  BaseParameters b;
  b.layout = L;
  std::vector<int> dep_acting;
  for (int k = 0; k < r; ++k) b.independent.push_back(acting[perm[k]]);
  for (Eigen::Index k = r; k < R.cols(); ++k) dep_acting.push_back(acting[perm[k]]);
  // beta_n = R11^-1 R12 in scaled columns; back to units: beta = D1^-1 beta_n D2.
  const Eigen::MatrixXd beta_n =
      R.topLeftCorner(r, r).triangularView<Eigen::Upper>().solve(R.topRightCorner(r, R.cols() - r));
  b.dependent = dep_acting;
  b.dependent.insert(b.dependent.end(), inert.begin(), inert.end());
  b.beta = Eigen::MatrixXd::Zero(r, static_cast<Eigen::Index>(b.dependent.size()));
  for (int j = 0; j < r; ++j)
    for (std::size_t k = 0; k < dep_acting.size(); ++k) {
      double c =
          beta_n(j, static_cast<Eigen::Index>(k)) * norms[dep_acting[k]] / norms[b.independent[j]];
      // The combinations are geometric constants (l1^2, anchor coordinates...); what QR leaves
      // of an exact zero is rounding.
      if (std::abs(c) < 1e-9) c = 0.0;
      b.beta(j, static_cast<Eigen::Index>(k)) = c;
    }
  return b;
}

}  // namespace dualv::identification
