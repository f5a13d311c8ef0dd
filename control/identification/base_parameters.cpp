#include "control/identification/base_parameters.hpp"

#include <fmt/format.h>

#include <Eigen/QR>
#include <cmath>
#include <random>
#include <stdexcept>

#include "control/identification/regressor.hpp"

namespace dualv::identification {

namespace {

// Standard parameters in the order they should represent base parameters: the inertias the
// motors and the plate feel first (crank ZZ about the motor axis, the plate's), then the
// couplers' rotary inertia and off-axis moment, then friction, and last what only ever acts
// through those (a coupler's mass and first moment along its axis, the cranks' masses).
std::vector<int> preferred_order(const ParameterLayout& L) {
  std::vector<int> order;
  using P = BodyParameter;
  for (int i = 0; i < L.n; ++i) order.push_back(L.crank(i, P::kZZ));
  for (P p : {P::kM, P::kMX, P::kMY, P::kZZ}) order.push_back(L.plate(p));
  for (int i = 0; i < L.n; ++i) order.push_back(L.coupler(i, P::kZZ));
  for (int i = 0; i < L.n; ++i) order.push_back(L.coupler(i, P::kMY));
  for (int i = 0; i < L.n; ++i) order.push_back(L.viscous(i));
  for (int i = 0; i < L.n; ++i) order.push_back(L.coulomb(i));
  for (int i = 0; i < L.n; ++i)
    for (P p : {P::kMX, P::kM}) order.push_back(L.coupler(i, p));
  for (int i = 0; i < L.n; ++i)
    for (P p : {P::kMX, P::kMY, P::kM}) order.push_back(L.crank(i, p));
  return order;
}

}  // namespace

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

  // The rank: QR with column pivoting (Eigen's rank-revealing Householder QR).
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Wn);
  qr.setThreshold(o.rank_tolerance);
  const int r = static_cast<int>(qr.rank());

  // Which r columns: pivoting would pick whichever is largest, so the base parameters would be
  // hard to read (e.g. a coupler's mass standing for the crank inertia it adds to). Instead the
  // columns are taken in an order of preference (preferred_order), each kept when its part
  // orthogonal to the columns kept before it is not negligible: the same R diagonal test, with
  // the order fixed. It must find the rank the pivoting found.
  std::vector<int> acting_index(static_cast<std::size_t>(P), -1);
  for (std::size_t k = 0; k < acting.size(); ++k) acting_index[acting[k]] = static_cast<int>(k);
  Eigen::MatrixXd Q(Wn.rows(), r);
  BaseParameters b;
  b.layout = L;
  std::vector<int> dep_acting;
  for (int k : preferred_order(L)) {
    const int a = acting_index[k];
    if (a < 0) continue;
    Eigen::VectorXd c = Wn.col(a);
    const int kept = static_cast<int>(b.independent.size());
    for (int pass = 0; pass < 2; ++pass)  // Gram-Schmidt twice: orthogonal to rounding
      c -= Q.leftCols(kept) * (Q.leftCols(kept).transpose() * c);
    if (c.norm() > std::sqrt(o.rank_tolerance) && kept < r) {
      Q.col(kept) = c.normalized();
      b.independent.push_back(k);
    } else {
      dep_acting.push_back(k);
    }
  }
  if (b.size() != r)
    throw std::logic_error(fmt::format(
        "base parameters: {} columns kept in order of preference, rank {} by pivoted QR", b.size(),
        r));
  // beta: W_2 = W_1 beta exactly (least squares on the full-rank W_1, in scaled columns),
  // then back to units: beta = D1^-1 beta_n D2.
  Eigen::MatrixXd W1n(Wn.rows(), r), W2n(Wn.rows(), static_cast<Eigen::Index>(dep_acting.size()));
  for (int j = 0; j < r; ++j) W1n.col(j) = Wn.col(acting_index[b.independent[j]]);
  for (std::size_t k = 0; k < dep_acting.size(); ++k)
    W2n.col(static_cast<Eigen::Index>(k)) = Wn.col(acting_index[dep_acting[k]]);
  const Eigen::MatrixXd beta_n = W1n.colPivHouseholderQr().solve(W2n);
  b.dependent = dep_acting;
  b.dependent.insert(b.dependent.end(), inert.begin(), inert.end());
  b.beta = Eigen::MatrixXd::Zero(r, static_cast<Eigen::Index>(b.dependent.size()));
  for (int j = 0; j < r; ++j)
    for (std::size_t k = 0; k < dep_acting.size(); ++k) {
      double c =
          beta_n(j, static_cast<Eigen::Index>(k)) * norms[dep_acting[k]] / norms[b.independent[j]];
      // The combinations are geometric constants (l1^2, anchor coordinates...); what the
      // solve leaves of an exact zero is rounding.
      if (std::abs(c) < 1e-9) c = 0.0;
      b.beta(j, static_cast<Eigen::Index>(k)) = c;
    }
  return b;
}
}  // namespace dualv::identification
