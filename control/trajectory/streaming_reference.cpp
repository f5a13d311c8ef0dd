#include "control/trajectory/streaming_reference.hpp"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <unsupported/Eigen/MatrixFunctions>

namespace dualv::trajectory {

const char* to_string(TargetStatus s) noexcept {
  switch (s) {
    case TargetStatus::kAccepted:
      return "accepted";
    case TargetStatus::kNonFinite:
      return "not finite";
    case TargetStatus::kOutsideWorkspace:
      return "outside the workspace";
    case TargetStatus::kNotActive:
      return "stream not active";
  }
  return "?";
}

namespace {

using Matrix5 = Eigen::Matrix<double, 5, 5>;

}  // namespace

StreamingReference::StreamingReference(const model::Model& model, const StreamingLimits& limits,
                                       const Workspace& workspace, double period)
    : model_(&model), data_(model), limits_(limits), workspace_(workspace), h_(period) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(period))
    throw std::invalid_argument(fmt::format("streaming reference: period {} s", period));
  const std::pair<const char*, double> named[] = {
      {"max_speed", limits.max_speed},
      {"max_acceleration", limits.max_acceleration},
      {"max_angular_speed", limits.max_angular_speed},
      {"max_angular_acceleration", limits.max_angular_acceleration}};
  for (const auto& [name, v] : named)
    if (!positive(v))
      throw std::invalid_argument(
          fmt::format("trajectory.streaming.{}: must be positive (got {})", name, v));
  // The acceleration bound is kStreamAccelerationGain * w * v: the largest w keeping both.
  w_ = std::min(
      limits.max_acceleration / (kStreamAccelerationGain * limits.max_speed),
      limits.max_angular_acceleration / (kStreamAccelerationGain * limits.max_angular_speed));
  // z = [y1, y2, y3, r, r_dot]; r is linear within a cycle (first-order hold).
  Matrix5 M = Matrix5::Zero();
  M(0, 0) = -w_;
  M(0, 3) = w_;
  M(1, 0) = w_;
  M(1, 1) = -w_;
  M(2, 1) = w_;
  M(2, 2) = -w_;
  M(3, 4) = 1.0;
  const Matrix5 phi = (M * h_).exp();  // Eigen's Pade approximant with scaling and squaring
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 5; ++j) phi_[i][j] = phi(i, j);
  reset(model.home);
  active_ = false;
}

void StreamingReference::reset(const Pose& actual) noexcept {
  target_ = r_ = actual;
  for (Pose& y : y_) y = actual;
  t_ = 0.0;
  active_ = true;
}

TargetStatus StreamingReference::set_target(const Pose& target) noexcept {
  TargetStatus s = TargetStatus::kAccepted;
  if (!active_)
    s = TargetStatus::kNotActive;
  else if (!target.allFinite())
    s = TargetStatus::kNonFinite;
  else if (!workspace_.x.contains(target[0]) || !workspace_.y.contains(target[1]) ||
           !workspace_.theta.contains(target[2]))
    s = TargetStatus::kOutsideWorkspace;
  if (s != TargetStatus::kAccepted) {
    ++refused_[static_cast<int>(s)];
    return s;
  }
  target_ = target;
  ++accepted_;
  return s;
}

void StreamingReference::hold() noexcept {
  // The moving point stops at once (its speed steps to 0, which the filter smooths: X_d_dd
  // stays continuous); X_d settles on it without overshoot.
  target_ = r_;
  active_ = false;
}

void StreamingReference::current(CartesianSample& out) const noexcept {
  const Pose &y1 = y_[0], &y2 = y_[1], &y3 = y_[2];
  out.X = y3;
  out.X_dot = w_ * (y2 - y3);
  out.X_dd = w_ * w_ * (y1 - 2.0 * y2 + y3);
  out.X_ddd = w_ * w_ * w_ * (r_ - 3.0 * y1 + 3.0 * y2 - y3);
}

SampleStatus StreamingReference::step(bool advance, Reference& out) noexcept {
  if (advance) {
    // Stage 1: the moving point, straight towards the target at most v h per cycle (x-y
    // together, so the plate speed |(x_dot, y_dot)| is bounded, not each axis).
    Pose r_next = r_;
    const Eigen::Vector2d d = target_.head<2>() - r_.head<2>();
    const double dist = d.norm();
    const double step = limits_.max_speed * h_;
    r_next.head<2>() = dist <= step ? Eigen::Vector2d(target_.head<2>())
                                    : Eigen::Vector2d(r_.head<2>() + d * (step / dist));
    const double dth = target_[2] - r_[2];
    const double step_th = limits_.max_angular_speed * h_;
    r_next[2] = std::abs(dth) <= step_th ? target_[2] : r_[2] + std::copysign(step_th, dth);
    const Pose r_dot = (r_next - r_) / h_;
    // Stage 2: the filter's exact step with r linear over the cycle.
    Pose y_next[3];
    for (int i = 0; i < 3; ++i)
      y_next[i] = phi_[i][0] * y_[0] + phi_[i][1] * y_[1] + phi_[i][2] * y_[2] + phi_[i][3] * r_ +
                  phi_[i][4] * r_dot;
    for (int i = 0; i < 3; ++i) y_[i] = y_next[i];
    r_ = r_next;
    t_ += h_;
  }
  out.t = t_;
  out.segment = 0;
  out.kind = SegmentKind::kDwell;
  out.phase = PhaseSample{};
  current(out.cartesian);
  return joint_reference(*model_, data_, out);
}

}  // namespace dualv::trajectory
