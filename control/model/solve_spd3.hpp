#pragma once
// 3x3 symmetric positive definite systems (the task-space mass matrix M, and Jm^T Jm of the
// forward kinematics and the projectors), written out: Eigen's LLT and FullPivLU cost
// several times more on these hot paths (the plant's RK4 solves 40 000 times per simulated
// second, the control cycle several times per cycle). noexcept, no allocation.
#include <Eigen/Core>
#include <algorithm>

namespace dualv::model {

// M = L D L^T without square roots (upper triangle of M read). Cholesky's pivots are the
// d_k squared, so `d_k > 0` is Eigen::LLT's positive-definiteness test.
class Ldlt3 {
 public:
  // False when a pivot is not above `relative_tolerance` times M's largest diagonal entry:
  // M is not positive definite, or (tolerance > 0) numerically singular. For SPD M every
  // pivot lies in [lambda_min, max diagonal], so a vanishing pivot means a vanishing
  // eigenvalue: the cheap stand-in for a reciprocal condition number.
  bool factor(const Eigen::Matrix3d& M, double relative_tolerance = 0.0) noexcept {
    const double floor = relative_tolerance * std::max({M(0, 0), M(1, 1), M(2, 2), 0.0});
    d0_ = M(0, 0);
    if (!(d0_ > floor)) return false;
    i0_ = 1.0 / d0_;
    l10_ = M(0, 1) * i0_;
    l20_ = M(0, 2) * i0_;
    d1_ = M(1, 1) - l10_ * M(0, 1);
    if (!(d1_ > floor)) return false;
    i1_ = 1.0 / d1_;
    const double m21 = M(1, 2) - l20_ * M(0, 1);
    l21_ = m21 * i1_;
    d2_ = M(2, 2) - l20_ * M(0, 2) - l21_ * m21;
    if (!(d2_ > floor)) return false;
    i2_ = 1.0 / d2_;
    return true;
  }

  // After a successful factor().
  void solve(const Eigen::Vector3d& b, Eigen::Vector3d& x) const noexcept {
    const double z0 = b[0];
    const double z1 = b[1] - l10_ * z0;
    const double z2 = b[2] - l20_ * z0 - l21_ * z1;
    x[2] = z2 * i2_;
    x[1] = z1 * i1_ - l21_ * x[2];
    x[0] = z0 * i0_ - l10_ * x[1] - l20_ * x[2];
  }

  // M^-1 = L^-T D^-1 L^-1, after a successful factor().
  Eigen::Matrix3d inverse() const noexcept {
    // L^-1 = [1 0 0; -l10 1 0; l10 l21 - l20, -l21, 1].
    const double a = -l10_, b = l10_ * l21_ - l20_, c = -l21_;
    Eigen::Matrix3d inv;
    inv(0, 0) = i0_ + a * a * i1_ + b * b * i2_;
    inv(0, 1) = a * i1_ + b * c * i2_;
    inv(0, 2) = b * i2_;
    inv(1, 1) = i1_ + c * c * i2_;
    inv(1, 2) = c * i2_;
    inv(2, 2) = i2_;
    inv(1, 0) = inv(0, 1);
    inv(2, 0) = inv(0, 2);
    inv(2, 1) = inv(1, 2);
    return inv;
  }

 private:
  double d0_ = 0, d1_ = 0, d2_ = 0, i0_ = 0, i1_ = 0, i2_ = 0, l10_ = 0, l20_ = 0, l21_ = 0;
};

// Solves M x = b; false when M is not positive definite.
inline bool solve_spd3(const Eigen::Matrix3d& M, const Eigen::Vector3d& b,
                       Eigen::Vector3d& x) noexcept {
  Ldlt3 ldlt;
  if (!ldlt.factor(M)) return false;
  ldlt.solve(b, x);
  return true;
}

}  // namespace dualv::model
