#pragma once
// The program sequencer: samples a Program at any time and turns the Cartesian reference into
// joint references through the model (IK, Jm, Jm_dot). The real-time face of control/trajectory:
// sample() is noexcept, allocates nothing and reports problems as a status.
//
//   q_d = IK(X_d),  q_d_dot = Jm X_d_dot,  q_d_dd = Jm X_d_dd + Jm_dot X_d_dot
//
// Joint references are continuous across segment joins whenever the Cartesian ones are (every
// join is at rest with zero acceleration unless a shape runs on the original clock, eq. 9).
#include <cstdint>

#include "control/model/model.hpp"
#include "control/trajectory/program.hpp"

namespace dualv::trajectory {

enum class SampleStatus : std::uint8_t {
  kOk = 0,
  kFinished,          // t >= program duration: holding the final pose at rest (refs valid)
  kInvalidTime,       // t is NaN or infinite: nothing written
  kKinematicsFailed,  // the model refused X_d (see Reference::model_status): joint refs stale
};
const char* to_string(SampleStatus s) noexcept;

struct Reference {
  double t = 0.0;           // program time [s]
  std::size_t segment = 0;  // index into Program::segments()
  SegmentKind kind = SegmentKind::kDwell;
  CartesianSample cartesian;  // X_d, X_d_dot, X_d_dd, jerk
  PhaseSample phase;          // lambda, lambda_dot, lambda_dd, lambda_ddd (shapes; zero else)
  model::JointVector q;       // q_d [rad]
  model::JointVector q_dot;   // q_d_dot [rad/s]
  model::JointVector q_dd;    // q_d_dd [rad/s^2]
  model::Status model_status = model::Status::kOk;
};

// Fills out.q, q_dot, q_dd and model_status from out.cartesian through the model (the joint
// half of Sequencer::sample, shared with the streaming reference). kKinematicsFailed when the
// model refuses X_d, else kOk. noexcept, no allocation (data is preallocated for `model`).
SampleStatus joint_reference(const model::Model& model, model::Data& data, Reference& out) noexcept;

class Sequencer {
 public:
  // Set-up: keeps a reference to `model` (must outlive the sequencer) and preallocates its
  // model data. The program should have been rebased (program.hpp) and pre-flighted.
  Sequencer(const model::Model& model, Program program);

  // Cartesian and joint references at program time t. noexcept, no allocation.
  SampleStatus sample(double t, Reference& out) noexcept;
  // Cartesian part only (no model). noexcept, no allocation.
  SampleStatus sample_cartesian(double t, Reference& out) const noexcept;

  const Program& program() const noexcept { return program_; }
  double duration() const noexcept { return program_.duration(); }
  const model::Model& model() const noexcept { return *model_; }

 private:
  const model::Model* model_;
  model::Data data_;
  Program program_;
};

}  // namespace dualv::trajectory
