#pragma once
// Weighted least squares for the base parameters (issue 16), set-up code.
//
// Each sample k gives three equations y_k = Jm^T tau_k = W_k phi_b (regressor.hpp). With the
// same torque noise of standard deviation sigma on every motor (four identical drives), the
// noise of y_k has the covariance sigma^2 Jm^T Jm, which differs from pose to pose and between
// the x, y and theta rows (the Dual-V's Jm has singular values 7.3 / 1.0 / 0.8 at home). Each
// sample's rows are weighted by the inverse Cholesky factor of Jm^T Jm (whitening), sigma is
// estimated from the weighted residuals, and cov(phi_b) = sigma^2 (W~^T W~)^-1 (Gautier 1997).
//
// Two refinements for data from a closed loop (docs/identification.md, "Why the plain least
// squares is biased in closed loop"):
// - Instrumental variables (Janot, Vandanjon, Gautier, IEEE TCST 22(1), 2014): the measured
//   motion's regressor W carries the encoder noise, and the torques the controller sends react
//   to that same noise, so W and y share an error and W^T y is biased. With the instruments Z
//   (the regressor of the reference motion, which the noise never reaches),
//   phi = (Z~^T W~)^-1 Z~^T y~ is consistent.
// - Correlated residuals: the rows are low-passed (zero_phase_filter.hpp), so neighbouring
//   residuals are correlated and sigma^2 (W~^T W~)^-1 is too small (it shrinks with every sample
//   kept, although the information does not grow). The covariance is the sandwich
//   B S B^T, B = (Z~^T W~)^-1, with S the Newey-West estimate (Bartlett weights; Econometrica
//   55(3), 1987) of the scores g_k = Z~_k^T e_k, summed over the lags up to
//   `correlation_time`: sigma does not depend on the decimation.
#include <Eigen/Core>
#include <vector>

namespace dualv::identification {

// Observations, three rows per sample: y = W phi + noise, with each sample's Jm^T Jm.
struct Observations {
  Eigen::MatrixXd W;                    // 3N x r
  Eigen::VectorXd y;                    // 3N
  std::vector<Eigen::Matrix3d> JmT_Jm;  // N
  // Optional instruments (3N x r, e.g. the regressor of the reference motion); empty: least
  // squares (Z = W).
  Eigen::MatrixXd Z;
  // Optional time of each sample [s] and the residuals' correlation time [s]: scores of samples
  // closer than it are summed in the covariance (Newey-West). Empty t or 0: white residuals.
  std::vector<double> t;
  double correlation_time = 0.0;
  int samples() const noexcept { return static_cast<int>(JmT_Jm.size()); }
};

struct Estimate {
  Eigen::VectorXd phi;         // base parameters
  Eigen::VectorXd sigma;       // their standard deviations
  Eigen::MatrixXd covariance;  // r x r
  double torque_noise = 0.0;   // estimated sigma of the motor torques [N m]
  // sigma / (sigma with white residuals): how much the residuals' correlation widens it.
  double correlation_factor = 1.0;
  bool instrumental = false;  // estimated with instruments
  // Condition number of the weighted regressor with its columns scaled to unit norm (the
  // excitation's quality: large means some parameters are barely excited).
  double condition = 0.0;
  Eigen::VectorXd weakest_direction;  // right singular vector of the smallest singular value
  int rows = 0;
};

// Throws std::invalid_argument when there are fewer rows than unknowns or sizes disagree.
// The condition number is that of the weighted W (the excitation's quality).
Estimate weighted_least_squares(const Observations& obs);

// Condition number of W with columns scaled to unit norm (1e300 when a column is zero).
double scaled_condition(const Eigen::MatrixXd& W);

}  // namespace dualv::identification
