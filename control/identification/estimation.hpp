#pragma once
// Weighted least squares for the base parameters (issue 16), set-up code.
//
// Each sample k gives three equations y_k = Jm^T tau_k = W_k phi_b (regressor.hpp). With the
// same torque noise of standard deviation sigma on every motor (four identical drives), the
// noise of y_k has the covariance sigma^2 Jm^T Jm, which differs from pose to pose and between
// the x, y and theta rows (the Dual-V's Jm has singular values 7.3 / 1.0 / 0.8 at home). Each
// sample's rows are weighted by the inverse Cholesky factor of Jm^T Jm (whitening), sigma is
// estimated from the weighted residuals, and cov(phi_b) = sigma^2 (W~^T W~)^-1 (Gautier 1997).
#include <Eigen/Core>
#include <vector>

namespace dualv::identification {

// Observations, three rows per sample: y = W phi + noise, with each sample's Jm^T Jm.
struct Observations {
  Eigen::MatrixXd W;                    // 3N x r
  Eigen::VectorXd y;                    // 3N
  std::vector<Eigen::Matrix3d> JmT_Jm;  // N
  int samples() const noexcept { return static_cast<int>(JmT_Jm.size()); }
};

struct Estimate {
  Eigen::VectorXd phi;         // base parameters
  Eigen::VectorXd sigma;       // their standard deviations
  Eigen::MatrixXd covariance;  // r x r
  double torque_noise = 0.0;   // estimated sigma of the motor torques [N m]
  // Condition number of the weighted regressor with its columns scaled to unit norm (the
  // excitation's quality: large means some parameters are barely excited).
  double condition = 0.0;
  Eigen::VectorXd weakest_direction;  // right singular vector of the smallest singular value
  int rows = 0;
};

// Throws std::invalid_argument when there are fewer rows than unknowns or sizes disagree.
Estimate weighted_least_squares(const Observations& obs);

// Condition number of W with columns scaled to unit norm (1e300 when a column is zero).
double scaled_condition(const Eigen::MatrixXd& W);

}  // namespace dualv::identification
