#include "control/controller/controller.hpp"

#include <fmt/format.h>

#include "common/yaml_reader.hpp"
#include "control/model/dynamics.hpp"
#include "control/model/kinematics.hpp"

namespace dualv::control {

const char* to_string(ControlStatus s) noexcept {
  switch (s) {
    case ControlStatus::kOk:
      return "ok";
    case ControlStatus::kReferenceInvalid:
      return "reference invalid";
    case ControlStatus::kModelFailed:
      return "model failed";
  }
  return "unknown";
}

namespace {
// Physical ranges of the gains: 1e6 N m/rad is 100x the stiff-mode stability bound of the
// Dual-V at 1 kHz (config/dualv.yaml); beyond it a value is a unit mistake.
constexpr double kMaxKp = 1e6;                  // [N m/rad]
constexpr double kMaxKd = 1e4;                  // [N m s/rad]
constexpr double kMaxVelocityCutoffHz = 10000;  // [Hz] half the fastest loop (20 kHz)
}  // namespace

ControlSetup load_control_config(const YAML::Node& node, int n) {
  ConfigProblems problems;
  YamlReader r(node, "controller", problems.sink());
  if (!r.valid()) {
    problems.sink()->push_back("controller: missing (gains kp, kd)");
    problems.finish();
  }
  ControlSetup setup;
  auto gain = [&](const std::string& key, double max_gain) {
    model::JointVector g = model::JointVector::Zero(n);
    std::vector<double> v;
    if (r.has(key) && node[key].IsSequence()) {
      v = r.numbers(key);
      if (static_cast<int>(v.size()) != n)
        r.problem(fmt::format("{}: must be one number or a list of {} (one per joint), got {}",
                              r.key_path(key), n, v.size()));
    } else {
      v.assign(n, r.number(key));
    }
    for (int i = 0; i < n && i < static_cast<int>(v.size()); ++i) {
      r.require(v[i] > 0.0 && v[i] <= max_gain, key,
                fmt::format("must be in (0, {}] (controller.hpp: physical gain ranges)", max_gain),
                v[i]);
      g[i] = v[i];
    }
    return g;
  };
  setup.controller.kp = gain("kp", kMaxKp);
  setup.controller.kd = gain("kd", kMaxKd);
  setup.controller.feedforward = r.boolean("feedforward", true);
  setup.controller.projection = r.boolean("projection", true);
  // Bounded here by a plausible filter; the loop's Nyquist rate bounds it again where the rate
  // is known (apps/experiment/robot_config.cpp).
  setup.estimator.velocity_cutoff_hz =
      r.in_range("velocity_cutoff_hz", 0.1, kMaxVelocityCutoffHz, 200.0);
  r.reject_unknown_keys();
  problems.finish();
  return setup;
}

Controller::Controller(const model::Model& model, ControllerConfig config)
    : model_(&model), config_(std::move(config)), desired_(model), measured_(model) {
  if (config_.kp.size() != model.n || config_.kd.size() != model.n)
    throw std::invalid_argument(fmt::format("controller: kp and kd need {} entries", model.n));
}

ControlStatus Controller::update(const trajectory::Reference& ref, const StateEstimate& est,
                                 ControlOutput& out) noexcept {
  const int n = model_->n;
  out.tau.setZero(n);
  out.tau_pd.setZero(n);
  out.tau_ff.setZero(n);
  out.tau_internal.setZero(n);
  out.error.setZero(n);
  out.error_dot.setZero(n);
  if (ref.model_status != model::Status::kOk || ref.q.size() != n || !ref.q.allFinite() ||
      !ref.q_dot.allFinite() || est.q.size() != n)
    return ControlStatus::kReferenceInvalid;

  out.error = ref.q - est.q;  // eq. 17
  out.error_dot = ref.q_dot - est.q_dot;
  out.tau_pd = config_.kp.cwiseProduct(out.error) + config_.kd.cwiseProduct(out.error_dot);
  out.tau = out.tau_pd;

  if (config_.feedforward) {  // eq. 18: exact inverse dynamics on the desired motion
    const auto& c = ref.cartesian;
    if (model::inverse_dynamics(*model_, desired_, c.X, c.X_dot, c.X_dd, out.tau_ff) !=
        model::Status::kOk) {
      out.tau.setZero(n);
      return ControlStatus::kModelFailed;
    }
    out.tau += out.tau_ff;
  }

  // Projectors at the estimated pose (eq. 19-20), from the estimator's model evaluation when
  // it has one (the normal case), else evaluated here.
  const model::Data* at_estimate = est.model;
  if (!at_estimate) {
    if (model::update_kinematics(*model_, measured_, est.X, model::Twist::Zero()) !=
            model::Status::kOk ||
        model::update_projectors(*model_, measured_) != model::Status::kOk) {
      out.tau.setZero(n);
      return ControlStatus::kModelFailed;
    }
    at_estimate = &measured_;
  }
  if (config_.projection) out.tau = at_estimate->R * out.tau;
  out.tau_internal.noalias() = at_estimate->N * out.tau;
  if (!out.tau.allFinite()) {
    out.tau.setZero(n);
    return ControlStatus::kModelFailed;
  }
  return ControlStatus::kOk;
}

}  // namespace dualv::control
