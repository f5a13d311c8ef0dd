#include "control/trajectory/sequencer.hpp"

#include <cmath>

#include "control/model/kinematics.hpp"

namespace dualv::trajectory {

const char* to_string(SampleStatus s) noexcept {
  switch (s) {
    case SampleStatus::kOk:
      return "ok";
    case SampleStatus::kFinished:
      return "finished";
    case SampleStatus::kInvalidTime:
      return "invalid time";
    case SampleStatus::kKinematicsFailed:
      return "kinematics failed";
  }
  return "?";
}

Sequencer::Sequencer(const model::Model& model, Program program)
    : model_(&model), data_(model), program_(std::move(program)) {}

SampleStatus Sequencer::sample_cartesian(double t, Reference& out) const noexcept {
  if (!std::isfinite(t)) return SampleStatus::kInvalidTime;
  out.t = t;
  out.segment = program_.sample(t, out.cartesian, out.phase);
  out.kind = program_.size() ? program_.segments()[out.segment].kind : SegmentKind::kDwell;
  return t >= program_.duration() ? SampleStatus::kFinished : SampleStatus::kOk;
}

SampleStatus Sequencer::sample(double t, Reference& out) noexcept {
  const SampleStatus st = sample_cartesian(t, out);
  if (st == SampleStatus::kInvalidTime) return st;
  const SampleStatus js = joint_reference(*model_, data_, out);
  return js == SampleStatus::kOk ? st : js;
}

SampleStatus joint_reference(const model::Model& model, model::Data& data,
                             Reference& out) noexcept {
  const CartesianSample& c = out.cartesian;
  // IK, Jm and Jm_dot at (X_d, X_d_dot); q_d_dot = Jm X_d_dot.
  out.model_status = model::update_kinematics(model, data, c.X, c.X_dot);
  if (out.model_status != model::Status::kOk) return SampleStatus::kKinematicsFailed;
  out.q = data.q;
  out.q_dot = data.q_dot;
  model::joint_acceleration(data, c.X_dot, c.X_dd, out.q_dd);  // Jm X_dd + Jm_dot X_dot
  return SampleStatus::kOk;
}

}  // namespace dualv::trajectory
