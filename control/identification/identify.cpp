#include "control/identification/identify.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "control/identification/regressor.hpp"
#include "control/identification/zero_phase_filter.hpp"
#include "control/model/kinematics.hpp"

namespace dualv::identification {

namespace {

// Linear interpolation of a uniformly sampled signal at fractional index s (clamped).
double at(const std::vector<double>& x, double s) {
  const double c = std::clamp(s, 0.0, static_cast<double>(x.size() - 1));
  const std::size_t i = std::min(static_cast<std::size_t>(c), x.size() - 2);
  const double f = c - static_cast<double>(i);
  return (1.0 - f) * x[i] + f * x[i + 1];
}

}  // namespace

ProcessedRecording process(const Recording& rec, const IdentifyOptions& o) {
  const std::size_t N = rec.size();
  ProcessedRecording p;
  if (N < 8 || rec.X.size() != N || rec.tau.size() != N)
    throw IdentificationError(fmt::format(
        "the recording has {} samples (poses {}, torques {}): too short to identify anything; "
        "record a run of several seconds",
        N, rec.X.size(), rec.tau.size()));
  const double h = rec.period;
  const ZeroPhaseLowPass lp(o.filter_order, o.cutoff_hz, 1.0 / h);
  const int n = static_cast<int>(rec.tau.front().size());
  const bool has_ref = rec.X_ref.size() == N;
  std::array<std::vector<double>, 3> X, Xd, Xdd, R, Rd, Rdd;
  for (int c = 0; c < 3; ++c) {
    std::vector<double> raw(N);
    for (std::size_t k = 0; k < N; ++k) raw[k] = rec.X[k][c];
    X[c] = lp.apply(raw);
    Xd[c] = central_difference(X[c], h);
    Xdd[c] = central_difference(Xd[c], h);
    if (!has_ref) continue;
    for (std::size_t k = 0; k < N; ++k) raw[k] = rec.X_ref[k][c];
    R[c] = lp.apply(raw);
    Rd[c] = central_difference(R[c], h);
    Rdd[c] = central_difference(Rd[c], h);
  }
  std::vector<std::vector<double>> tau(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    std::vector<double> raw(N);
    for (std::size_t k = 0; k < N; ++k) raw[k] = rec.tau[k][i];
    tau[static_cast<std::size_t>(i)] = lp.apply(raw);
  }
  const double shift = o.torque_delay / h;  // the torque acting at sample k was sent at k - shift
  p.t = rec.t;
  p.X.resize(N);
  p.X_dot.resize(N);
  p.X_dd.resize(N);
  p.tau.resize(N);
  for (std::size_t k = 0; k < N; ++k) {
    p.X[k] = model::Pose(X[0][k], X[1][k], X[2][k]);
    p.X_dot[k] = model::Twist(Xd[0][k], Xd[1][k], Xd[2][k]);
    p.X_dd[k] = model::Twist(Xdd[0][k], Xdd[1][k], Xdd[2][k]);
    if (has_ref) {
      p.X_ref.emplace_back(R[0][k], R[1][k], R[2][k]);
      p.X_ref_dot.emplace_back(Rd[0][k], Rd[1][k], Rd[2][k]);
      p.X_ref_dd.emplace_back(Rdd[0][k], Rdd[1][k], Rdd[2][k]);
    }
    p.tau[k].resize(n);
    for (int i = 0; i < n; ++i)
      p.tau[k][i] = at(tau[static_cast<std::size_t>(i)], static_cast<double>(k) - shift);
  }
  return p;
}

Observations observations(const model::Model& model, const BaseParameters& base,
                          const ProcessedRecording& p, const IdentifyOptions& o) {
  const std::size_t N = p.t.size();
  const double h = N > 1 ? (p.t.back() - p.t.front()) / static_cast<double>(N - 1) : 1.0;
  const auto skip = static_cast<std::size_t>(std::ceil(o.trim / h + std::abs(o.torque_delay) / h));
  const bool iv = o.instruments && p.X_ref.size() == N;
  model::Data data(model), ref_data(model);
  RegressorRows W, Wr;
  std::vector<Eigen::Matrix<double, 3, Eigen::Dynamic>> rows, zrows;
  std::vector<Eigen::Vector3d> ys;
  Observations obs;
  const std::size_t step = static_cast<std::size_t>(std::max(1, o.decimation));
  auto base_columns = [&](const RegressorRows& full) {
    Eigen::Matrix<double, 3, Eigen::Dynamic> W1(3, base.size());
    for (int j = 0; j < base.size(); ++j) W1.col(j) = full.col(base.independent[j]);
    return W1;
  };
  for (std::size_t k = skip; k + skip < N; k += step) {
    if (regressor(model, data, p.X[k], p.X_dot[k], p.X_dd[k], W) != model::Status::kOk) continue;
    if ((data.q_dot.array().abs() < o.min_joint_speed).any()) continue;
    if (iv && regressor(model, ref_data, p.X_ref[k], p.X_ref_dot[k], p.X_ref_dd[k], Wr) !=
                  model::Status::kOk)
      continue;
    rows.push_back(base_columns(W));
    if (iv) zrows.push_back(base_columns(Wr));
    ys.push_back(data.Jm.transpose() * p.tau[k]);
    obs.JmT_Jm.push_back(data.Jm.transpose() * data.Jm);
    obs.t.push_back(p.t[k]);
  }
  const auto M = static_cast<Eigen::Index>(rows.size());
  obs.W.resize(3 * M, base.size());
  obs.y.resize(3 * M);
  if (iv) obs.Z.resize(3 * M, base.size());
  for (Eigen::Index k = 0; k < M; ++k) {
    obs.W.middleRows(3 * k, 3) = rows[static_cast<std::size_t>(k)];
    if (iv) obs.Z.middleRows(3 * k, 3) = zrows[static_cast<std::size_t>(k)];
    obs.y.segment<3>(3 * k) = ys[static_cast<std::size_t>(k)];
  }
  obs.correlation_time = o.correlation_periods / o.cutoff_hz;
  return obs;
}

Identification identify(const model::Model& model, const Eigen::VectorXd& nominal_standard,
                        const Recording& rec, const IdentifyOptions& o) {
  Identification id;
  id.base = find_base_parameters(model);
  id.nominal = id.base.from_standard(nominal_standard);
  const ProcessedRecording p = process(rec, o);
  const Observations obs = observations(model, id.base, p, o);
  const double h = rec.period;
  id.duration = static_cast<double>(obs.samples()) * h * std::max(1, o.decimation);
  const int r = id.base.size();
  if (id.duration < o.min_duration || obs.samples() < 3 * r)
    throw IdentificationError(fmt::format(
        "not enough motion to identify {} base parameters: {:.2f} s of samples with every joint "
        "faster than {} rad/s ({} samples after decimation by {}), need at least {:.2f} s and {} "
        "samples; record a longer run that keeps every joint moving (the excitation of "
        "`dualv identify`, or lower identify.estimation.min_joint_speed)",
        r, id.duration, o.min_joint_speed, obs.samples(), o.decimation, o.min_duration, 3 * r));
  id.estimate = weighted_least_squares(obs);
  id.correlation_time = obs.correlation_time;
  if (!(id.estimate.condition <= o.max_condition)) {
    // Name the parameters the motion excites least: the largest entries of the weakest
    // direction.
    std::vector<int> idx(static_cast<std::size_t>(r));
    for (int j = 0; j < r; ++j) idx[static_cast<std::size_t>(j)] = j;
    const Eigen::VectorXd& v = id.estimate.weakest_direction;
    std::sort(idx.begin(), idx.end(),
              [&](int a, int b) { return std::abs(v[a]) > std::abs(v[b]); });
    std::string weak;
    for (int k = 0; k < std::min(r, 3); ++k)
      weak += (k ? ", " : "") + id.base.meaning(idx[static_cast<std::size_t>(k)]);
    throw IdentificationError(fmt::format(
        "the motion is not exciting enough: condition number {} of the scaled regressor "
        "(limit identify.estimation.max_condition = {:.3g}); least excited: {}. Use a richer "
        "motion: the "
        "excitation of `dualv identify` (more harmonics, larger amplitudes in "
        "config/identify.yaml), with rotation of the plate and every joint reversing",
        id.estimate.condition < 1e300 ? fmt::format("{:.3g}", id.estimate.condition)
                                      : std::string("infinite (a base parameter never acts)"),
        o.max_condition, weak));
  }
  return id;
}

TorqueComparison compare_torques(const model::Model& model, const BaseParameters& base,
                                 const Eigen::VectorXd& phi_b, const Recording& rec,
                                 const IdentifyOptions& o) {
  TorqueComparison c;
  const ProcessedRecording p = process(rec, o);
  model::Data data(model);
  RegressorRows W;
  double se = 0.0, sm = 0.0;
  int count = 0;
  for (std::size_t k = 0; k < p.t.size(); ++k) {
    if (regressor(model, data, p.X[k], p.X_dot[k], p.X_dd[k], W) != model::Status::kOk) continue;
    if (model::update_projectors(model, data) != model::Status::kOk) continue;
    Eigen::Vector3d F = Eigen::Vector3d::Zero();
    for (int j = 0; j < base.size(); ++j) F += W.col(base.independent[j]) * phi_b[j];
    const model::JointVector predicted = data.JmT_pinv * F;
    const model::JointVector measured = data.R * p.tau[k];
    c.t.push_back(p.t[k]);
    c.measured.push_back(measured);
    c.predicted.push_back(predicted);
    se += (measured - predicted).squaredNorm();
    sm += measured.squaredNorm();
    count += static_cast<int>(measured.size());
  }
  if (count > 0) {
    c.rms_error = std::sqrt(se / count);
    c.rms_measured = std::sqrt(sm / count);
  }
  return c;
}

}  // namespace dualv::identification
