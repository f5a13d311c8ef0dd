#pragma once
// Kinematics of the planar n-RRR mechanism. Real-time safe: noexcept, no allocation.
#include "control/model/model.hpp"

namespace dualv::model {

// Jm^T Jm counts as singular (kParallelSingular) when its determinant falls below this times
// its largest diagonal entry cubed: always when its condition number exceeds 2.7e13
// (control/model/solve_spd3.hpp, Ldlt3).
inline constexpr double kParallelSingularTolerance = 1e-12;

// Below this |sin(crank, coupler)| a chain counts as serially singular (kSerialSingular):
// Jm's row would divide by ~0.
inline constexpr double kSerialSingularTolerance = 1e-9;

// q_i = atan2(C_i - A_i) + s_i acos((l1^2 + d^2 - l2^2) / (2 l1 d)), d = |C_i - A_i|.
// Also fills data.chain[*] (anchors, elbows). q is resized to model.n.
Status inverse_kinematics(const Model& model, Data& data, const Pose& X, JointVector& q) noexcept;

// Inverse kinematics at X plus Jm and Jm_dot at (X, X_dot): fills data.q, data.q_dot,
// data.Jm, data.Jm_dot, data.qdd_bias, data.chain. Velocity closure: q_dot = Jm X_dot.
Status update_kinematics(const Model& model, Data& data, const Pose& X,
                         const Twist& X_dot) noexcept;

// What the dynamics need of update_kinematics, without the joint angles (atan2) and the
// rows of Jm_dot: fills data.chain, data.Jm, data.q_dot and data.qdd_bias = Jm_dot X_dot;
// leaves data.q and data.Jm_dot as they were.
Status update_velocity_kinematics(const Model& model, Data& data, const Pose& X,
                                  const Twist& X_dot) noexcept;

// Joint accelerations for a plate acceleration, after update_kinematics:
// q_dd = Jm X_dd + Jm_dot X_dot.
void joint_acceleration(const Data& data, const Twist& X_dot, const Twist& X_dd,
                        JointVector& q_dd) noexcept;

struct FkOptions {
  int max_iterations = 50;
  double tolerance = 1e-13;       // on the joint residual |q_ik(X) - q|_2 [rad]
  double step_tolerance = 1e-10;  // a Gauss-Newton step below this [m, rad]: converged
  // Joint angles whose least-squares pose leaves a residual above this [rad] cannot come
  // from one rigid plate (a slipped or broken encoder): kInconsistent.
  double max_residual = 1e-3;
};

struct FkResult {
  Status status = Status::kNotConverged;
  int iterations = 0;
  // |q_ik(X) - q|_2 [rad] at the returned X. Zero up to round-off for consistent q; for
  // measured q of a redundant machine it is the encoders' disagreement (a health signal).
  double residual = 0.0;
};

// Forward kinematics: Gauss-Newton on Jm from `seed` (e.g. the previous pose), converging to
// the least-squares pose when the n > 3 joint angles are not exactly consistent. On failure X
// is left at `seed`; never NaN. On success leaves `data` at the returned pose at rest
// (chain, Jm; data.q = the model's angles on the branch of `q`; zero velocities).
FkResult forward_kinematics(const Model& model, Data& data, const JointVector& q, const Pose& seed,
                            Pose& X, const FkOptions& options = {}) noexcept;

// Computes data.JmT_pinv, data.R and data.N from data.Jm (after update_kinematics).
// R = Jm^{T*} Jm^T projects torques onto range(Jm); N = I - R holds internal forces.
Status update_projectors(const Model& model, Data& data) noexcept;

struct SingularityMeasures {
  // Smallest singular value of Jm with the rotation column scaled by
  // characteristic_length (translations and rotation comparable) [rad/m]:
  // goes to zero at a parallel (type II) singularity.
  double parallel = 0.0;
  // Per chain: |sin| of the crank-coupler angle; zero at a serial (type I) singularity.
  std::array<double, kMaxChains> serial{};
  double min_serial = 0.0;
};

// After update_kinematics.
SingularityMeasures singularity_measures(const Model& model, const Data& data) noexcept;

// Singular values of Jm (unscaled), largest first, after update_kinematics.
Eigen::Vector3d jacobian_singular_values(const Data& data) noexcept;

}  // namespace dualv::model
