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
  // False when M is not positive definite (a pivot <= 0), or, with a tolerance > 0, when it
  // is numerically singular: det M = d0 d1 d2 below tolerance * (largest diagonal entry)^3.
  // The largest diagonal entry lies in [lambda_max / 3, lambda_max], so that refuses every M
  // whose condition number exceeds 27 / tolerance: the cheap stand-in for a reciprocal
  // condition number.
  bool factor(const Eigen::Matrix3d& M, double relative_tolerance = 0.0) noexcept {
    d0_ = M(0, 0);
    if (!(d0_ > 0.0)) return false;
    i0_ = 1.0 / d0_;
    l10_ = M(0, 1) * i0_;
    l20_ = M(0, 2) * i0_;
    d1_ = M(1, 1) - l10_ * M(0, 1);
    if (!(d1_ > 0.0)) return false;
    i1_ = 1.0 / d1_;
    const double m21 = M(1, 2) - l20_ * M(0, 1);
    l21_ = m21 * i1_;
    d2_ = M(2, 2) - l20_ * M(0, 2) - l21_ * m21;
    if (!(d2_ > 0.0)) return false;
    i2_ = 1.0 / d2_;
    const double largest = std::max({M(0, 0), M(1, 1), M(2, 2)});
    return !(d0_ * d1_ * d2_ <= relative_tolerance * largest * largest * largest);
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

// Solves M x = b; false when M is not positive definite (Sylvester: the leading minors
// M00, M00 M11 - M01^2 and det M are positive). By the adjugate, with a single division: the
// plant's RK4 stages depend on each other, so the latency of this solve (not its throughput)
// bounds the simulation speed, and LDL^T puts three divisions one after the other. For the
// mass matrix (condition number ~1e2) the result agrees with LDL^T to ~1e-14 (tests).
inline bool solve_spd3(const Eigen::Matrix3d& M, const Eigen::Vector3d& b,
                       Eigen::Vector3d& x) noexcept {
  const double m00 = M(0, 0), m01 = M(0, 1), m02 = M(0, 2);
  const double m11 = M(1, 1), m12 = M(1, 2), m22 = M(2, 2);
  const double c00 = m11 * m22 - m12 * m12;  // cofactors (symmetric)
  const double c01 = m02 * m12 - m01 * m22;
  const double c02 = m01 * m12 - m02 * m11;
  const double c11 = m00 * m22 - m02 * m02;
  const double c12 = m01 * m02 - m00 * m12;
  const double c22 = m00 * m11 - m01 * m01;
  const double det = m00 * c00 + m01 * c01 + m02 * c02;
  if (!(m00 > 0.0 && c22 > 0.0 && det > 0.0)) return false;
  const double inv = 1.0 / det;
  x[0] = (c00 * b[0] + c01 * b[1] + c02 * b[2]) * inv;
  x[1] = (c01 * b[0] + c11 * b[1] + c12 * b[2]) * inv;
  x[2] = (c02 * b[0] + c12 * b[1] + c22 * b[2]) * inv;
  return true;
}

}  // namespace dualv::model
