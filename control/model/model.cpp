#include "control/model/model.hpp"

namespace dualv::model {

const char* to_string(Status s) noexcept {
  switch (s) {
    case Status::kOk:
      return "ok";
    case Status::kUnreachable:
      return "unreachable";
    case Status::kSerialSingular:
      return "serial singularity";
    case Status::kParallelSingular:
      return "parallel singularity";
    case Status::kInvalidInput:
      return "invalid input";
    case Status::kNotConverged:
      return "not converged";
    case Status::kInconsistent:
      return "inconsistent joint angles";
  }
  return "unknown";
}

Data::Data(const Model& model)
    : n(model.n),
      q(JointVector::Zero(model.n)),
      q_dot(JointVector::Zero(model.n)),
      Jm(JointJacobian::Zero(model.n, 3)),
      Jm_dot(JointJacobian::Zero(model.n, 3)),
      qdd_bias(JointVector::Zero(model.n)),
      JmT_pinv(JointJacobian::Zero(model.n, 3)),
      R(JointMatrix::Zero(model.n, model.n)),
      N(JointMatrix::Zero(model.n, model.n)) {}

}  // namespace dualv::model
