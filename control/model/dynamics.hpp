#pragma once
// Exact rigid-body dynamics of all 2n + 1 bodies (plate, n cranks, n couplers with their
// real rotational inertia), in the task coordinates X. Replaces the paper's two-mass
// approximation (eq. 1-3) with the exact quantity: F_X = M(X) X_dd + h(X, X_dot) + g(X),
// tau = Jm^{T*} F_X (minimum-norm actuator torques, eq. 3 without tau_3 approximated).
// Real-time safe: noexcept, no allocation.
#include "control/model/model.hpp"

namespace dualv::model {

// One chain's inertia as the dynamics use it. A coupler whose centre of mass lies on its axis
// (com.y == 0), at d from the elbow, is exactly the point masses m (1 - d/l2) at B_i and
// m d/l2 at C_i plus the rotary inertia J = I - m d (l2 - d) (same mass, centre of mass and
// inertia about it): the share at B_i turns with the crank, the one at C_i rides on the
// plate. The crank with the elbow share is a pure rotation about A_i with the inertia
// I_A = I + m |com|^2 + m_B l1^2 (a rotation keeps lengths). An off-axis coupler is not
// split (shares and J zero: it needs the general body form) and I_A is the crank's alone.
struct ChainInertia {
  bool split = false;
  double elbow_mass = 0.0;        // m_B [kg]
  double anchor_mass = 0.0;       // m_C [kg]
  double coupler_rotary = 0.0;    // J [kg m^2]
  double crank_about_axis = 0.0;  // I_A [kg m^2]
};
ChainInertia chain_inertia(const Chain& ch) noexcept;

// Fills data.M, data.h, data.g and the velocity kinematics (update_velocity_kinematics:
// chain, Jm, q_dot, qdd_bias; not the joint angles data.q).
Status update_dynamics(const Model& model, Data& data, const Pose& X, const Twist& X_dot) noexcept;

// Generalized force F_X = M X_dd + h + g needed for the motion (X, X_dot, X_dd).
Status generalized_force(const Model& model, Data& data, const Pose& X, const Twist& X_dot,
                         const Twist& X_dd, Twist& F) noexcept;

// Minimum-norm joint torques [N m] realising (X, X_dot, X_dd): tau = Jm^{T*} F_X.
Status inverse_dynamics(const Model& model, Data& data, const Pose& X, const Twist& X_dot,
                        const Twist& X_dd, JointVector& tau) noexcept;

// X_dd = M^-1 (Jm^T tau - h - g): the plate acceleration produced by joint torques.
Status forward_dynamics(const Model& model, Data& data, const Pose& X, const Twist& X_dot,
                        const JointVector& tau, Twist& X_dd) noexcept;

// Energies [J] of all bodies, computed from body velocities and positions.
double kinetic_energy(const Model& model, Data& data, const Pose& X, const Twist& X_dot) noexcept;
double potential_energy(const Model& model, Data& data, const Pose& X) noexcept;

}  // namespace dualv::model
