#pragma once
// The standard dynamic parameters of a planar n-RRR machine (issue 16): for each of the
// 2n + 1 rigid bodies the four barycentric parameters of planar rigid-body dynamics in its
// link frame (origin at the body's proximal joint: A_i for a crank, B_i for a coupler, the
// plate's reference point p for the plate), then per joint a viscous and a Coulomb friction
// coefficient. The dynamics are linear in these (regressor.hpp).
//
//   ZZ = I + m |c|^2   inertia about the frame origin [kg m^2]
//   MX = m c_x, MY = m c_y   first moments [kg m] (c: centre of mass in the link frame)
//   M  = m             mass [kg]
//   Fv, Fc             joint friction tau_f = Fv q_dot + Fc sign(q_dot) [N m s/rad], [N m]
//
// Set-up code (allocates, std::string): never on the real-time path.
#include <Eigen/Core>
#include <string>

#include "control/model/model.hpp"

namespace dualv::identification {

enum class BodyParameter : int { kZZ = 0, kMX = 1, kMY = 2, kM = 3 };
inline constexpr int kParametersPerBody = 4;

// Viscous and Coulomb friction of one joint, the model tau_f = viscous q_dot + coulomb sign(q_dot).
struct JointFriction {
  double viscous = 0.0;  // [N m s/rad]
  double coulomb = 0.0;  // [N m]
};

// Where each standard parameter sits in the vector phi, for a machine with n chains:
// crank 1..n, coupler 1..n, plate (four each, in BodyParameter order), Fv 1..n, Fc 1..n.
struct ParameterLayout {
  int n = 0;
  int crank(int chain, BodyParameter p) const noexcept {
    return kParametersPerBody * chain + static_cast<int>(p);
  }
  int coupler(int chain, BodyParameter p) const noexcept {
    return kParametersPerBody * (n + chain) + static_cast<int>(p);
  }
  int plate(BodyParameter p) const noexcept {
    return kParametersPerBody * 2 * n + static_cast<int>(p);
  }
  int viscous(int chain) const noexcept { return kParametersPerBody * (2 * n + 1) + chain; }
  int coulomb(int chain) const noexcept { return kParametersPerBody * (2 * n + 1) + n + chain; }
  int size() const noexcept { return kParametersPerBody * (2 * n + 1) + 2 * n; }

  // Short name, e.g. "crank1.ZZ", "plate.M", "joint3.Fc".
  std::string name(int index) const;
  // Unit, e.g. "kg m^2".
  std::string unit(int index) const;
};

// phi of a model's bodies and the joints' friction (one JointFriction for every joint).
Eigen::VectorXd standard_parameters(const model::Model& model, const JointFriction& friction);

// The model with its bodies' masses, centres of mass and inertias taken from phi (the
// geometry from `geometry`): mass = M, com = (MX, MY) / M, inertia = ZZ - M |com|^2. A body
// whose M is not positive keeps com = 0 (then MX, MY must be 0). Friction entries are ignored.
model::Model model_with_parameters(const model::Model& geometry, const Eigen::VectorXd& phi);

}  // namespace dualv::identification
