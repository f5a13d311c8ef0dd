#pragma once
// The n-RRR machine's dynamics linear in its standard parameters (parameters.hpp), issue 16:
//
//   Jm^T tau = F_X = W(X, X_dot, X_dd) phi
//
// W (3 x P) is written body by body from the Newton-Euler equations of a planar rigid body in
// its link frame, with origin O at its proximal joint (acceleration a_O, angle psi, angular
// velocity w, acceleration alpha, d = Rot(psi) e_x, e = E d):
//   force      f   = M (a_O - g) + MX (alpha E d - w^2 d) + MY (alpha E e - w^2 e)
//   moment at O n_O = ZZ alpha + (MX d + MY e) x (a_O - g)
// and the principle of virtual power F_X = sum_b J_O^T f + J_psi^T n_O (J_O, J_psi: the
// body's origin and angle Jacobians with respect to X, from the chain closure of
// control/model/kinematics.hpp). The joint friction adds Jm_i^T (Fv_i q_dot_i + Fc_i sign q_dot_i).
//
// Only this actuated projection is observable: torques in the null space of Jm^T (internal,
// antagonistic torques, paper eq. 19-20) do not move the plate, so the identification uses
// the three rows of Jm^T tau per sample, never the four motor torques on their own.
//
// This is an implementation of its own: control/model/dynamics.cpp builds M(X) and h(X, X_dot)
// by virtual power with the couplers split into point masses; the tests check W phi against it.
#include <Eigen/Core>

#include "control/identification/parameters.hpp"
#include "control/model/model.hpp"

namespace dualv::identification {

using RegressorRows = Eigen::Matrix<double, 3, Eigen::Dynamic>;

// Fills W (resized to 3 x ParameterLayout{n}.size()) for the motion (X, X_dot, X_dd); data's
// velocity kinematics are updated on the way. Coulomb columns use sign(q_dot) (0 at rest).
// Allocation-free once W has its size.
model::Status regressor(const model::Model& model, model::Data& data, const model::Pose& X,
                        const model::Twist& X_dot, const model::Twist& X_dd,
                        RegressorRows& W) noexcept;

}  // namespace dualv::identification
