#include "control/identification/excitation.hpp"

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>

#include "control/identification/estimation.hpp"
#include "control/identification/regressor.hpp"
#include "control/model/dynamics.hpp"
#include "control/model/kinematics.hpp"
#include "control/trajectory/preflight.hpp"

namespace dualv::identification {

namespace {

using Coefficients = std::array<Eigen::VectorXd, 3>;

trajectory::Shape fourier_shape(const model::Pose& centre, const Coefficients& a,
                                const Coefficients& b, double scale) {
  std::array<trajectory::TermList, 3> terms;
  for (int c = 0; c < 3; ++c)
    for (Eigen::Index k = 0; k < a[c].size(); ++k) {
      trajectory::ShapeTerm t;
      t.a = scale * a[c][k];
      t.alpha = 1;
      t.n1 = static_cast<double>(k + 1);
      t.b = scale * b[c][k];
      t.beta = 1;
      t.n2 = static_cast<double>(k + 1);
      terms[c].push(t);
    }
  return trajectory::Shape(centre, terms[0], terms[1], terms[2]);
}

// Largest |excursion| of each coordinate over a period.
model::Pose excursion(const trajectory::Shape& s, int samples) {
  model::Pose m = model::Pose::Zero();
  for (int j = 0; j < samples; ++j) {
    const double l = 2.0 * std::numbers::pi * j / samples;
    m = m.cwiseMax((s.position(l) - s.centre()).cwiseAbs());
  }
  return m;
}

// Largest fraction of a limit the cruise motion reaches (<= 1 fits); infinity when a pose is
// not usable.
double limit_ratio(const model::Model& model, model::Data& data, const trajectory::Shape& s,
                   double period, const trajectory::Limits& lim, int samples) {
  const double w = 2.0 * std::numbers::pi / period;
  double worst = 0.0;
  trajectory::ShapePoint pt;
  model::JointVector tau;
  for (int j = 0; j < samples; ++j) {
    s.evaluate(2.0 * std::numbers::pi * j / samples, pt);
    const model::Twist Xd = pt.d1 * w, Xdd = pt.d2 * w * w;
    if (model::inverse_dynamics(model, data, pt.p, Xd, Xdd, tau) != model::Status::kOk)
      return 1e300;
    const auto sm = model::singularity_measures(model, data);
    if (sm.parallel < lim.min_parallel_singularity || sm.min_serial < lim.min_serial_singularity)
      return 1e300;
    worst = std::max({worst, data.q_dot.cwiseAbs().maxCoeff() / lim.max_joint_speed,
                      Xdd.head<2>().norm() / lim.max_plate_acceleration,
                      std::abs(Xdd.z()) / lim.max_plate_angular_acceleration,
                      tau.cwiseAbs().maxCoeff() / lim.max_joint_torque});
  }
  return worst;
}

struct Candidate {
  Coefficients a, b;
  double scale = 0.0;
  double condition = 1e300;
};

// Normalises the coefficients so each coordinate reaches its amplitude, then finds the scale
// (<= 1) that keeps the motion within limit_fraction of every limit, and the condition number.
void evaluate(const model::Model& model, model::Data& data, const BaseParameters& base,
              const trajectory::Limits& lim, const ExcitationConfig& cfg, Candidate& c) {
  const model::Pose ex = excursion(fourier_shape(model.home, c.a, c.b, 1.0), 90);
  for (int k = 0; k < 3; ++k)
    if (ex[k] > 0.0) {
      c.a[k] *= cfg.amplitude[k] / ex[k];
      c.b[k] *= cfg.amplitude[k] / ex[k];
    }
  c.scale = 1.0;
  c.condition = 1e300;
  for (int iter = 0; iter < 12; ++iter) {
    const trajectory::Shape s = fourier_shape(model.home, c.a, c.b, c.scale);
    const double ratio = limit_ratio(model, data, s, cfg.period, lim, 60) / cfg.limit_fraction;
    if (ratio <= 1.0) {
      c.condition = excitation_condition(model, base, s, cfg.period, 60);
      return;
    }
    c.scale *= ratio < 1e6 ? 0.97 / std::sqrt(ratio) : 0.5;  // torque grows up to scale^2
  }
}

}  // namespace

double excitation_condition(const model::Model& model, const BaseParameters& base,
                            const trajectory::Shape& shape, double period, int samples) {
  const double w = 2.0 * std::numbers::pi / period;
  model::Data data(model);
  RegressorRows W;
  Eigen::MatrixXd stacked(3 * samples, base.size());
  trajectory::ShapePoint pt;
  for (int j = 0; j < samples; ++j) {
    shape.evaluate(2.0 * std::numbers::pi * (j + 0.5) / samples, pt);
    if (regressor(model, data, pt.p, pt.d1 * w, pt.d2 * w * w, W) != model::Status::kOk)
      return 1e300;
    for (int c = 0; c < base.size(); ++c)
      stacked.block(3 * j, c, 3, 1) = W.col(base.independent[c]);
  }
  return scaled_condition(stacked);
}

Excitation design_excitation(const model::Model& model, const BaseParameters& base,
                             const trajectory::Limits& limits, const ExcitationConfig& cfg) {
  const int H = cfg.harmonics;
  if (H < 1 || H > static_cast<int>(trajectory::kMaxTerms))
    throw std::invalid_argument(
        fmt::format("excitation.harmonics must be in [1, {}] (got {})", trajectory::kMaxTerms, H));
  model::Data data(model);
  std::mt19937_64 rng(cfg.seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  Candidate best;
  for (int k = 0; k < cfg.candidates; ++k) {
    Candidate c;
    for (int d = 0; d < 3; ++d) {
      c.a[d].resize(H);
      c.b[d].resize(H);
      for (int h = 0; h < H; ++h) {
        c.a[d][h] = u(rng) / (h + 1);
        c.b[d][h] = u(rng) / (h + 1);
      }
    }
    evaluate(model, data, base, limits, cfg, c);
    if (c.condition < best.condition) best = c;
  }
  for (int k = 0; k < cfg.refinements && best.condition < 1e300; ++k) {
    Candidate c = best;
    for (int d = 0; d < 3; ++d)
      for (int h = 0; h < H; ++h) {
        c.a[d][h] += 0.15 * g(rng) * c.a[d].cwiseAbs().maxCoeff();
        c.b[d][h] += 0.15 * g(rng) * c.b[d].cwiseAbs().maxCoeff();
      }
    evaluate(model, data, base, limits, cfg, c);
    if (c.condition < best.condition) best = c;
  }
  if (!(best.condition < 1e300))
    throw std::runtime_error(
        "excitation: no Fourier motion with these amplitudes stays within the trajectory limits "
        "and away from singularities; lower identify.excitation.amplitude or lengthen its period");

  Excitation ex;
  ex.a = best.a;
  ex.b = best.b;
  ex.scale = best.scale;
  for (int d = 0; d < 3; ++d) {
    ex.a[d] *= best.scale;
    ex.b[d] *= best.scale;
  }
  const trajectory::Shape shape = fourier_shape(model.home, ex.a, ex.b, 1.0);
  ex.condition = excitation_condition(model, base, shape, cfg.period);
  trajectory::TimingLaw law;
  law.kind = trajectory::TimingKind::kSmooth;
  law.tau = cfg.blend;
  law.T = cfg.periods * cfg.period + cfg.blend;  // cruise speed (2 pi periods) / (T - tau)
  law.lambda0 = 0.0;
  law.lambda_f = 2.0 * std::numbers::pi * cfg.periods;
  ex.program = trajectory::Program(model.home);
  ex.program.add_ptp(shape.position(0.0), cfg.ptp_duration, "ptp to the excitation");
  ex.program.add_shape(shape, law, "excitation (Fourier series)");
  ex.program.add_dwell(0.2, "dwell");
  ex.program.add_ptp(model.home, cfg.ptp_duration, "ptp home");
  ex.shape_segment = 1;
  trajectory::preflight_or_throw(model, ex.program, limits);
  return ex;
}

}  // namespace dualv::identification
