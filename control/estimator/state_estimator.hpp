#pragma once
// Joint and plate state from encoder positions (the paper measures no velocities, eq. 17):
//   q_dot: backward difference of q, then a first-order low-pass at cutoff f_c;
//   X:     forward kinematics seeded with the previous X; X_dot = Jm^+ q_dot.
// A cycle without a fresh position for a joint (drivers::DriveFeedback::fresh false: its TPDO
// did not arrive, drivers/actuator_set.hpp) extrapolates that joint from its last fresh
// position at its estimated velocity and holds the velocity; the next fresh position's
// difference is taken over the cycles since the last one. Holding the stale position instead
// reads as the joint stopping and then jumping: at the shipped kp (7000 N m/rad) one lost TPDO
// at 3 rad/s is a ~20 N m torque step. The safety layer bounds how long this goes on
// (safety.watchdogs.stale_feedback_cycles, safety/safety_filter.cpp).
//
// Phase lag of the velocity estimate at frequency f (sample period dt):
//   atan(f / f_c) from the low-pass + pi f dt from the backward difference (half a sample);
//   e.g. f_c = 200 Hz, dt = 1 ms: 2.9 deg at 10 Hz, 14 deg at 50 Hz. Raising f_c cuts the lag
//   and passes more encoder quantisation noise into the D term.
// Real-time safe: update() is noexcept and allocates nothing.
#include <cstdint>

#include "control/model/kinematics.hpp"

namespace dualv::control {

struct EstimatorConfig {
  double velocity_cutoff_hz = 200.0;  // low-pass cutoff of the differentiator [Hz]
};

enum class EstimateStatus : std::uint8_t {
  kOk = 0,
  kFkFailed,      // forward kinematics did not converge: X held at its last good value
  kInvalidInput,  // NaN/Inf position or wrong size: nothing updated
};

struct StateEstimate {
  model::JointVector q;      // measured crank angles [rad]
  model::JointVector q_dot;  // filtered joint velocities [rad/s]
  model::Pose X = model::Pose::Zero();
  model::Twist X_dot = model::Twist::Zero();
  EstimateStatus status = EstimateStatus::kOk;
  int fk_iterations = 0;
  double fk_residual = 0.0;  // encoder disagreement at X [rad] (forward_kinematics)
  // The model evaluated at X (Jm, Jm^{T*}, R, N), owned by the estimator; valid while status
  // is kOk. The controller projects with it instead of evaluating the model again.
  const model::Data* model = nullptr;
};

class StateEstimator {
 public:
  StateEstimator(const model::Model& model, const EstimatorConfig& config, double period_s);

  // Starts from a known pose (e.g. after forward kinematics at start-up): no velocity transient.
  void reset(const model::JointVector& q, const model::Pose& X) noexcept;
  // fresh_mask: bit i set when joint i's position is new this cycle (default: all).
  EstimateStatus update(const model::JointVector& q_measured,
                        std::uint32_t fresh_mask = ~std::uint32_t{0}) noexcept;
  const StateEstimate& estimate() const noexcept { return est_; }
  double alpha() const noexcept { return alpha_; }

 private:
  const model::Model* model_;
  model::Data data_;
  double period_;
  double alpha_;                  // low-pass smoothing factor dt / (dt + 1 / (2 pi f_c))
  model::JointVector q_last_;     // each joint's last fresh position
  model::JointVector stale_for_;  // cycles since it (0: fresh this cycle)
  StateEstimate est_;
};

}  // namespace dualv::control
