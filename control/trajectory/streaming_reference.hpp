#pragma once
// The streaming reference: the plate follows the latest valid pose setpoint from an external
// source (teleoperation, a planner streaming over LCM), through a generator that turns any
// setpoint, including a jump, into a smooth motion with bounded speed and acceleration.
//
// Two stages, per cycle of period h:
//   1. a moving point r walks towards the target along a straight line, |r_dot| <= v (the
//      plate's x-y speed limit; theta on its own with the angular limit);
//   2. r, linearly interpolated between cycles, drives a critically damped third-order
//      filter (three first-order lags with the pole w): X_d = y3, X_d_dot = w (y2 - y3),
//      X_d_dd = w^2 (y1 - 2 y2 + y3), X_d_ddd = w^3 (r - 3 y1 + 3 y2 - y3),
//      discretised exactly (matrix exponential, set-up), so the samples are those of the
//      continuous filter.
// Why this pair: the filter's impulse response h(t) = w^3 t^2 e^{-wt} / 2 is positive with
// unit area, so X_d is a weighted average of past r (never leaves the convex workspace box
// the targets are checked against, never overshoots), |X_d_dot| <= max |r_dot| <= v, and
// |X_d_dd| <= v * integral|h'| = 4 e^-2 w v. w is chosen from the acceleration limits, so the
// limits hold by construction, not by clamping (a clamp would break X_d_dot = d/dt X_d). A
// setpoint jump changes r_dot only; X_d_dd stays continuous (h(0) = h'(0) = 0), so the
// feedforward torque, which follows X_d_dd, has no step either.
//
// Construction throws (set-up); everything else is noexcept and allocation-free (RT path).
#include <cstdint>

#include "control/model/model.hpp"
#include "control/trajectory/limits.hpp"
#include "control/trajectory/sample.hpp"
#include "control/trajectory/sequencer.hpp"

namespace dualv::trajectory {

// integral of |h'(t)| dt / w for the triple pole: the acceleration bound is this * w * v.
inline constexpr double kStreamAccelerationGain = 0.5413411329464508;  // 4 e^-2
// integral of |h''(t)| dt / w^2: the jerk bound is this * w^2 * v.
inline constexpr double kStreamJerkGain =
    0.6200250151492581;  // 2 g'(2 - sqrt 2) - 2 g'(2 + sqrt 2)

enum class TargetStatus : std::uint8_t {
  kAccepted = 0,
  kNonFinite,         // NaN or Inf in the setpoint: refused, the target is unchanged
  kOutsideWorkspace,  // outside trajectory.limits.workspace: refused, the target is unchanged
  kNotActive,         // the stream has ended (hold()) or not begun: refused
};
const char* to_string(TargetStatus s) noexcept;

class StreamingReference {
 public:
  // Set-up. `model` must outlive the reference. Throws std::invalid_argument naming the
  // problem when the period or a limit is not positive and finite.
  StreamingReference(const model::Model& model, const StreamingLimits& limits,
                     const Workspace& workspace, double period);

  // At rest at `actual` (the robot's pose), the target = `actual`, active. noexcept.
  void reset(const Pose& actual) noexcept;
  // A new setpoint. Refused (status, target unchanged, counted) when non-finite, outside the
  // workspace box or not active.
  TargetStatus set_target(const Pose& target) noexcept;
  // A normal end of the stream: the moving point stops where it is, the filter comes to rest
  // smoothly there; later setpoints are refused (kNotActive).
  void hold() noexcept;

  // Advances one period when `advance` (otherwise: the current reference, at rest until the
  // first advance) and writes the Cartesian and joint references. kKinematicsFailed when the
  // model refuses X_d (as Sequencer::sample). noexcept, no allocation.
  SampleStatus step(bool advance, Reference& out) noexcept;
  // The current Cartesian reference, without advancing.
  void current(CartesianSample& out) const noexcept;

  bool active() const noexcept { return active_; }
  const Pose& target() const noexcept { return target_; }
  double bandwidth() const noexcept { return w_; }  // [rad/s]
  double time() const noexcept { return t_; }       // time advanced since reset [s]
  const StreamingLimits& limits() const noexcept { return limits_; }

  std::uint64_t accepted() const noexcept { return accepted_; }
  std::uint64_t refused(TargetStatus s) const noexcept {
    return refused_[static_cast<int>(s) < 4 ? static_cast<int>(s) : 0];
  }
  std::uint64_t refused() const noexcept {  // for any reason
    return refused(TargetStatus::kNonFinite) + refused(TargetStatus::kOutsideWorkspace) +
           refused(TargetStatus::kNotActive);
  }

 private:
  const model::Model* model_;
  model::Data data_;
  StreamingLimits limits_;
  Workspace workspace_;
  double h_;
  double w_;
  // Rows 0..2 of exp(M h) for z = [y1, y2, y3, r, r_dot]: the exact step of the filter.
  double phi_[3][5] = {};
  Pose target_ = Pose::Zero();
  Pose r_ = Pose::Zero();
  Pose y_[3] = {Pose::Zero(), Pose::Zero(), Pose::Zero()};
  double t_ = 0.0;
  bool active_ = false;
  std::uint64_t accepted_ = 0;
  std::uint64_t refused_[4] = {};
};

}  // namespace dualv::trajectory
