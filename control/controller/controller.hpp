#pragma once
// The paper's controller (eq. 17-20): joint PD + computed feedforward, projected onto
// range(Jm) so no torque is spent on internal (antagonistic) forces:
//   e = q_d - q,   tau_PD = Kp e + Kd e_dot                                 (eq. 17)
//   tau_ff = Jm^{T*} (M X_d_dd + h + g) on the desired X_d, X_d_dot, X_d_dd  (eq. 18, exact)
//   tau* = R (tau_PD + tau_ff),  R = Jm^{T*} Jm^T                            (eq. 19-20)
// R is evaluated at the estimated (measured) pose: internal forces are a property of the
// mechanism where it actually is. Feedforward and projection can each be switched off.
// Real-time safe: update() is noexcept, allocates nothing, never returns NaN for valid input.
#include <yaml-cpp/yaml.h>

#include <cstdint>

#include "control/estimator/state_estimator.hpp"
#include "control/model/model.hpp"
#include "control/trajectory/sequencer.hpp"

namespace dualv::control {

struct ControllerConfig {
  model::JointVector kp;  // [N m / rad] per joint
  model::JointVector kd;  // [N m s / rad] per joint
  bool feedforward = true;
  bool projection = true;
};

// Reads `controller:` (kp, kd: a number for every joint or a list of n; feedforward,
// projection, velocity_cutoff_hz). Throws dualv::ConfigError naming the key.
struct ControlSetup {
  ControllerConfig controller;
  EstimatorConfig estimator;
};
ControlSetup load_control_config(const YAML::Node& controller_node, int n_joints);

enum class ControlStatus : std::uint8_t {
  kOk = 0,
  kReferenceInvalid,  // the reference had no valid joint values: zero torque commanded
  kModelFailed,       // inverse dynamics or projectors failed: zero torque commanded
};
const char* to_string(ControlStatus s) noexcept;

struct ControlOutput {
  model::JointVector tau;           // tau*: what the controller asks for [N m]
  model::JointVector tau_pd;        // Kp e + Kd e_dot
  model::JointVector tau_ff;        // computed feedforward (zero when disabled)
  model::JointVector error;         // e = q_d - q [rad]
  model::JointVector error_dot;     // e_dot [rad/s]
  model::JointVector tau_internal;  // N tau: the internal-force part of tau (at the estimate)
};

class Controller {
 public:
  Controller(const model::Model& model, ControllerConfig config);

  ControlStatus update(const trajectory::Reference& ref, const StateEstimate& est,
                       ControlOutput& out) noexcept;

  const ControllerConfig& config() const noexcept { return config_; }
  ControllerConfig& config() noexcept { return config_; }  // between runs, not in the cycle

 private:
  const model::Model* model_;
  ControllerConfig config_;
  model::Data desired_;   // model data at X_d (feedforward)
  model::Data measured_;  // model data at the estimate when the estimate carries none
};

}  // namespace dualv::control
