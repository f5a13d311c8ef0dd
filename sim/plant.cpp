#include "sim/plant.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "control/model/dynamics.hpp"
#include "control/model/kinematics.hpp"
#include "control/model/solve_spd3.hpp"

namespace dualv::sim {

namespace {

constexpr double kTwoPi = 6.283185307179586476925286766559;
// advance() refuses periods needing more RK4 steps than this (a unit mistake, e.g. ms for s).
constexpr double kMaxStepsPerAdvance = 1e6;

// CiA 402 target torque 6071h: INT16 per mille of the rated torque 6076h, rounded half away
// from zero and saturated to the INT16 range, as the host's wire codec does. Kept private
// here on purpose: firmware_if/units.hpp owns the wire units; the plant only needs the
// resolution the drive sees.
double quantise_per_mille(double tau, double rated) noexcept {
  const double pm = tau * 1000.0 / rated;
  const double clamped = std::clamp(pm, -32768.0, 32767.0);
  return std::round(clamped) * rated / 1000.0;  // std::round: half away from zero
}

model::Body scaled(const model::Body& b, const MismatchPercent& p) noexcept {
  model::Body out = b;
  out.mass *= 1.0 + p.mass / 100.0;
  out.inertia *= 1.0 + p.inertia / 100.0;
  return out;
}

}  // namespace

PlantConfig PlantConfig::ideal() noexcept {
  PlantConfig c;
  c.friction.enabled = false;
  c.mismatch.enabled = false;
  c.encoder.enabled = false;
  c.torque_quantisation.enabled = false;
  c.current_loop.enabled = false;
  c.saturation.enabled = false;
  c.transport_delay.enabled = false;
  return c;
}

model::Model make_true_model(const model::Model& configured, const PlantConfig& config) noexcept {
  if (config.true_model) return *config.true_model;
  model::Model m = configured;
  if (!config.mismatch.enabled) return m;
  for (int i = 0; i < m.n; ++i) {
    m.chains[i].crank = scaled(configured.chains[i].crank, config.mismatch.crank);
    m.chains[i].coupler = scaled(configured.chains[i].coupler, config.mismatch.coupler);
  }
  m.plate = scaled(configured.plate, config.mismatch.plate);
  return m;
}

const char* to_string(PlantStatus s) noexcept {
  switch (s) {
    case PlantStatus::kOk:
      return "ok";
    case PlantStatus::kUnreachable:
      return "unreachable";
    case PlantStatus::kInvalidCommand:
      return "invalid command";
    case PlantStatus::kInvalidPeriod:
      return "invalid period";
  }
  return "unknown";
}

Plant::Plant(const model::Model& configured, const PlantConfig& config)
    : true_model_(make_true_model(configured, config)), config_(config), data_(true_model_) {
  const int n = true_model_.n;
  if (model::LaneDynamics::supports(true_model_)) lanes_.emplace(true_model_, config_.allow_avx2);
  for (auto& slot : delay_line_) slot = model::JointVector::Zero(n);
  pending_ = model::JointVector::Zero(n);
  target_ = model::JointVector::Zero(n);
  tau0_ = model::JointVector::Zero(n);
  motor_ = model::JointVector::Zero(n);
  friction_ = model::JointVector::Zero(n);
  inv_smoothing_velocity_ = 1.0 / config_.friction.smoothing_velocity;
  out_.q = model::JointVector::Zero(n);
  out_.q_dot = model::JointVector::Zero(n);
  out_.q_measured = model::JointVector::Zero(n);
  out_.tau_command = model::JointVector::Zero(n);
  out_.tau_target = model::JointVector::Zero(n);
  out_.tau_applied = model::JointVector::Zero(n);
  out_.tau_friction = model::JointVector::Zero(n);
  out_.tau_internal = model::JointVector::Zero(n);
  if (reset(true_model_.home) != PlantStatus::kOk) {
    // load_model() guarantees a usable home; a hand-built model may not have one.
    latched_ = PlantStatus::kUnreachable;
  }
}

PlantStatus Plant::reset(const model::Pose& X, const model::Twist& X_dot) noexcept {
  const model::Status s = model::update_kinematics(true_model_, data_, X, X_dot);
  if (s != model::Status::kOk) return PlantStatus::kUnreachable;
  y_.X = X;
  y_.X_dot = X_dot;
  latched_ = PlantStatus::kOk;
  for (auto& slot : delay_line_) slot.setZero();
  head_ = 0;
  pending_.setZero();
  target_.setZero();
  tau0_.setZero();
  out_.time = 0.0;
  out_.cycle = 0;
  out_.fault = model::Status::kOk;
  out_.tau_command.setZero();
  out_.q = data_.q;  // the unwrapping of later angles starts from here
  refresh_output();
  return PlantStatus::kOk;
}

double Plant::drive_target(double tau) const noexcept {
  if (config_.torque_quantisation.enabled)
    tau = quantise_per_mille(tau, config_.torque_quantisation.rated_torque);
  if (config_.saturation.enabled) {
    const double peak = config_.saturation.peak_torque;
    tau = std::clamp(tau, -peak, peak);
  }
  return tau;
}

PlantStatus Plant::command(const model::JointVector& tau) noexcept {
  const int n = true_model_.n;
  if (tau.size() != n || !tau.allFinite()) {
    // A drive given garbage produces no torque (firmware_if's codecs map NaN to 0 too).
    out_.tau_command.setZero();
    pending_.setZero();
    return PlantStatus::kInvalidCommand;
  }
  out_.tau_command = tau;
  for (int i = 0; i < n; ++i) pending_[i] = drive_target(tau[i]);
  return PlantStatus::kOk;
}

double Plant::joint_friction(double q_dot) const noexcept {
  const auto& fr = config_.friction;
  if (!fr.enabled) return 0.0;
  const double z = q_dot * inv_smoothing_velocity_;
  const double z2 = z * z;
  const double sign =
      z2 < 1.0 ? z * (15.0 - z2 * (10.0 - 3.0 * z2)) * 0.125 : std::copysign(1.0, z);
  return fr.coulomb * sign + fr.viscous * q_dot;
}

void Plant::friction(const model::JointVector& q_dot, model::JointVector& f) const noexcept {
  for (int i = 0; i < true_model_.n; ++i) f[i] = joint_friction(q_dot[i]);
}

model::Status Plant::acceleration(const model::Pose& X, const model::Twist& X_dot,
                                  const model::JointVector& tau_motor,
                                  model::Twist& X_dd) noexcept {
  // The equation of model::forward_dynamics, X_dd = M^-1 (Jm^T tau - h - g), with the
  // joint friction subtracted from the motor torques. Friction needs q_dot = Jm X_dot,
  // which update_dynamics computes on the way, so the solve is written out here instead
  // of calling forward_dynamics after a second kinematics pass (tests check both agree).
  const int n = true_model_.n;
  if (tau_motor.size() != n) return model::Status::kInvalidInput;
  model::Twist F;
  const model::Mat3* M = nullptr;
  if (lanes_) {
    const model::Status s = lanes_->update(X, X_dot, lane_out_);
    if (s != model::Status::kOk) return s;
    const auto& o = lane_out_;
    for (int i = 0; i < n; ++i) friction_[i] = joint_friction(o.q_dot[i]);
    F = -o.bias;
    for (int i = 0; i < n; ++i) {
      const double t = tau_motor[i] - friction_[i];  // F_X = Jm^T tau
      F[0] += o.jm0[i] * t;
      F[1] += o.jm1[i] * t;
      F[2] += o.jm2[i] * t;
    }
    M = &o.M;
  } else {
    const model::Status s = model::update_dynamics(true_model_, data_, X, X_dot);
    if (s != model::Status::kOk) return s;
    friction(data_.q_dot, friction_);
    F = -data_.h - data_.g;
    for (int i = 0; i < n; ++i)
      F += (tau_motor[i] - friction_[i]) * data_.Jm.row(i).transpose();  // F_X = Jm^T tau
    M = &data_.M;
  }
  if (!model::solve_spd3(*M, F, X_dd)) return model::Status::kParallelSingular;
  if (!X_dd.allFinite()) return model::Status::kInvalidInput;
  return model::Status::kOk;
}

model::Status Plant::derivative(const State& y, double decay, State& dy) noexcept {
  // Motor torque `decay` = exp(-s / T) into the step: the exact solution of the current
  // loop's lag T tau_dot = target - tau with the target held over the cycle.
  motor_ = target_ + (tau0_ - target_) * decay;
  dy.X = y.X_dot;
  return acceleration(y.X, y.X_dot, motor_, dy.X_dot);
}

PlantStatus Plant::advance(double period) noexcept {
  if (!(period > 0.0) || !std::isfinite(period) || period / config_.max_step > kMaxStepsPerAdvance)
    return PlantStatus::kInvalidPeriod;
  if (latched_ != PlantStatus::kOk) return latched_;

  // Transport delay: the command of cycle k - D acts during cycle k (D = 0 when off).
  const int D = config_.transport_delay.enabled ? config_.transport_delay.cycles : 0;
  const int slots = D + 1;
  delay_line_[head_] = pending_;
  target_ = delay_line_[(head_ + 1) % slots];
  head_ = (head_ + 1) % slots;

  // Equal steps no longer than max_step (the 1e-9 keeps 1 ms / 0.1 ms at 10 steps, not 11).
  const int steps = std::max(1, static_cast<int>(std::ceil(period / config_.max_step - 1e-9)));
  const double h = period / steps;
  const bool lag = config_.current_loop.enabled;
  const double e_half = lag ? std::exp(-0.5 * h / config_.current_loop.time_constant) : 0.0;
  const double e_full = e_half * e_half;

  for (int k = 0; k < steps; ++k) {
    // Classic RK4 on y = (X, X_dot); stage torques at s = 0, h/2, h of this step.
    State k1, k2, k3, k4, tmp;
    model::Status s = derivative(y_, lag ? 1.0 : 0.0, k1);
    if (s == model::Status::kOk) {
      tmp.X = y_.X + 0.5 * h * k1.X;
      tmp.X_dot = y_.X_dot + 0.5 * h * k1.X_dot;
      s = derivative(tmp, e_half, k2);
    }
    if (s == model::Status::kOk) {
      tmp.X = y_.X + 0.5 * h * k2.X;
      tmp.X_dot = y_.X_dot + 0.5 * h * k2.X_dot;
      s = derivative(tmp, e_half, k3);
    }
    if (s == model::Status::kOk) {
      tmp.X = y_.X + h * k3.X;
      tmp.X_dot = y_.X_dot + h * k3.X_dot;
      s = derivative(tmp, e_full, k4);
    }
    if (s == model::Status::kOk) {
      tmp.X = y_.X + (h / 6.0) * (k1.X + 2.0 * k2.X + 2.0 * k3.X + k4.X);
      tmp.X_dot = y_.X_dot + (h / 6.0) * (k1.X_dot + 2.0 * k2.X_dot + 2.0 * k3.X_dot + k4.X_dot);
      if (!tmp.X.allFinite() || !tmp.X_dot.allFinite()) s = model::Status::kInvalidInput;
    }
    if (s != model::Status::kOk) {
      // Freeze at the last good state (y_ untouched) and latch.
      latched_ = PlantStatus::kUnreachable;
      out_.fault = s;
      break;
    }
    y_ = tmp;
    tau0_ = target_ + (tau0_ - target_) * e_full;
    out_.time += h;
  }
  if (!lag) tau0_ = target_;
  ++out_.cycle;
  refresh_output();
  return latched_;
}

void Plant::refresh_output() noexcept {
  out_.X = y_.X;
  out_.X_dot = y_.X_dot;
  out_.tau_target = target_;
  out_.tau_applied = tau0_;
  if (model::update_kinematics(true_model_, data_, y_.X, y_.X_dot) != model::Status::kOk) return;
  const int n = true_model_.n;
  // Continuous joint angles: IK's atan2 branch may jump by 2 pi, a real joint does not.
  for (int i = 0; i < n; ++i) out_.q[i] += std::remainder(data_.q[i] - out_.q[i], kTwoPi);
  out_.q_dot = data_.q_dot;
  const double resolution = kTwoPi / static_cast<double>(config_.encoder.counts_per_revolution);
  for (int i = 0; i < n; ++i) {
    // Round to the nearest count (error within +-1/2 count): the position the drive's
    // wire codec (rad_to_counts) would produce from a continuous angle.
    const double c = std::round(out_.q[i] / resolution);
    out_.counts[i] = static_cast<std::int64_t>(c);
    out_.q_measured[i] = config_.encoder.enabled ? c * resolution : out_.q[i];
  }
  friction(out_.q_dot, out_.tau_friction);
  if (model::update_projectors(true_model_, data_) == model::Status::kOk) {
    out_.tau_internal.noalias() = data_.N * out_.tau_applied;
    out_.internal_norm = out_.tau_internal.norm();
  }
}

double Plant::kinetic_energy() noexcept {
  return model::kinetic_energy(true_model_, data_, y_.X, y_.X_dot);
}

double Plant::potential_energy() noexcept {
  return model::potential_energy(true_model_, data_, y_.X);
}

}  // namespace dualv::sim
