#include "control/estimator/state_estimator.hpp"

#include <cmath>
#include <stdexcept>

namespace dualv::control {

StateEstimator::StateEstimator(const model::Model& model, const EstimatorConfig& config,
                               double period_s)
    : model_(&model), data_(model), period_(period_s) {
  if (!(period_s > 0.0)) throw std::invalid_argument("estimator: period must be > 0");
  if (!(config.velocity_cutoff_hz > 0.0))
    throw std::invalid_argument("estimator: velocity_cutoff_hz must be > 0");
  const double rc = 1.0 / (2.0 * M_PI * config.velocity_cutoff_hz);
  alpha_ = period_s / (period_s + rc);
  reset(model::JointVector::Zero(model.n), model.home);
}

void StateEstimator::reset(const model::JointVector& q, const model::Pose& X) noexcept {
  q_last_ = q;
  stale_for_ = model::JointVector::Zero(model_->n);
  est_.q = q;
  est_.q_dot = model::JointVector::Zero(model_->n);
  est_.X = X;
  est_.X_dot.setZero();
  est_.status = EstimateStatus::kOk;
  est_.model = nullptr;
  if (model::update_kinematics(*model_, data_, X, model::Twist::Zero()) == model::Status::kOk &&
      model::update_projectors(*model_, data_) == model::Status::kOk)
    est_.model = &data_;
}

EstimateStatus StateEstimator::update(const model::JointVector& q_measured,
                                      std::uint32_t fresh_mask) noexcept {
  if (q_measured.size() != model_->n || !q_measured.allFinite())
    return est_.status = EstimateStatus::kInvalidInput;
  for (int i = 0; i < model_->n; ++i) {
    if ((fresh_mask >> i & 1U) != 0) {
      // Over the cycles since the last fresh position (one when none was lost).
      const double raw = (q_measured[i] - q_last_[i]) / ((stale_for_[i] + 1.0) * period_);
      est_.q_dot[i] += alpha_ * (raw - est_.q_dot[i]);
      q_last_[i] = q_measured[i];
      stale_for_[i] = 0.0;
      est_.q[i] = q_measured[i];
    } else {
      stale_for_[i] += 1.0;
      est_.q[i] = q_last_[i] + est_.q_dot[i] * stale_for_[i] * period_;
    }
  }
  model::Pose X;
  // Seeded with a constant-velocity prediction of the pose: Gauss-Newton then needs one
  // step less than from the previous pose (the FK is most of the estimator's cost).
  const model::Pose seed = est_.X + est_.X_dot * period_;
  const model::FkResult fk = model::forward_kinematics(*model_, data_, est_.q, seed, X);
  est_.fk_iterations = fk.iterations;
  est_.fk_residual = fk.residual;
  est_.model = nullptr;
  if (fk.status != model::Status::kOk) return est_.status = EstimateStatus::kFkFailed;
  est_.X = X;
  // forward_kinematics leaves data_ at X. X_dot = (Jm^T Jm)^-1 Jm^T q_dot = (Jm^{T*})^T q_dot.
  if (model::update_projectors(*model_, data_) != model::Status::kOk)
    return est_.status = EstimateStatus::kFkFailed;
  est_.X_dot.noalias() = data_.JmT_pinv.transpose() * est_.q_dot;
  est_.model = &data_;
  return est_.status = EstimateStatus::kOk;
}

}  // namespace dualv::control
