#pragma once
// Base (identifiable) parameters, issue 16: the standard parameters (parameters.hpp) are not
// all identifiable from Jm^T tau. Some never act (a crank's mass: its origin does not move;
// first moments without gravity), others act only in fixed combinations (a coupler's mass at
// its elbow moves with the crank tip, l1 from the motor axis; its mass at the anchor rides on
// the plate). The combinations are found numerically, by QR with column pivoting of the
// regressor stacked over random states (Gautier 1990):
//
//   W = [W_1 W_2] P,  W_2 = W_1 beta  =>  W phi = W_1 phi_b,  phi_b = phi_1 + beta phi_2
//
// phi_1: the r independent standard parameters (one per base parameter), phi_2: the others.
// Set-up code (allocates).
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "control/identification/parameters.hpp"
#include "control/model/model.hpp"

namespace dualv::identification {

struct BaseParameters {
  ParameterLayout layout;
  std::vector<int> independent;  // standard indices of phi_1, in base-parameter order
  std::vector<int> dependent;    // standard indices of phi_2
  Eigen::MatrixXd beta;          // r x (P - r)

  int size() const noexcept { return static_cast<int>(independent.size()); }
  // phi_b of a standard parameter vector.
  Eigen::VectorXd from_standard(const Eigen::VectorXd& phi) const;
  // The base columns of a regressor: W_1 = W(:, independent).
  Eigen::MatrixXd columns(const Eigen::MatrixXd& W) const;
  // A standard vector with the given base parameters: phi_2 taken from `reference` (e.g. the
  // nominal model), phi_1 = phi_b - beta phi_2. It has the same dynamics as any standard
  // vector with these base parameters.
  Eigen::VectorXd to_standard(const Eigen::VectorXd& phi_b, const Eigen::VectorXd& reference) const;
  // "crank1.ZZ + 0.0784 coupler1.M - 0.28 coupler1.MX": what base parameter j is.
  std::string meaning(int j) const;
  std::string name(int j) const { return layout.name(independent[j]) + (has_terms(j) ? "R" : ""); }
  std::string unit(int j) const { return layout.unit(independent[j]); }
  bool has_terms(int j) const;  // base parameter j combines several standard ones
  // Standard parameters that act in no combination (all-zero regressor column).
  std::vector<int> inert() const;
};

struct BaseParameterOptions {
  int states = 200;                             // random states stacked
  std::uint64_t seed = 16;                      // deterministic
  double rank_tolerance = 1e-8;                 // |R_kk| / |R_00| below which a column is dependent
  model::Twist pose_spread{0.08, 0.08, 0.3};    // [m, m, rad] about home
  model::Twist speed{0.5, 0.5, 3.0};            // [m/s, m/s, rad/s]
  model::Twist acceleration{10.0, 10.0, 60.0};  // [m/s^2, m/s^2, rad/s^2]
};

// Throws std::runtime_error when too few random states are valid poses of the model.
BaseParameters find_base_parameters(const model::Model& model,
                                    const BaseParameterOptions& options = {});

}  // namespace dualv::identification
