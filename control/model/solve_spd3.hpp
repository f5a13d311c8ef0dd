#pragma once
// Solves the 3x3 symmetric positive definite system M x = b (upper triangle of M used), for
// the task-space mass matrix. Written out: Eigen's LLT cost ~3x more on this hot path (the
// plant's RK4 calls it 40 000 times per simulated second). noexcept, no allocation.
#include <Eigen/Core>

namespace dualv::model {

// False when M is not positive definite (Eigen::LLT's criterion): LDL^T without square roots,
// whose pivots d_k are those of Cholesky squared, so the test is the same.
inline bool solve_spd3(const Eigen::Matrix3d& M, const Eigen::Vector3d& b,
                       Eigen::Vector3d& x) noexcept {
  const double d0 = M(0, 0);
  if (!(d0 > 0.0)) return false;
  const double i0 = 1.0 / d0;
  const double l10 = M(0, 1) * i0, l20 = M(0, 2) * i0;
  const double d1 = M(1, 1) - l10 * M(0, 1);
  if (!(d1 > 0.0)) return false;
  const double i1 = 1.0 / d1;
  const double m21 = M(1, 2) - l20 * M(0, 1);
  const double l21 = m21 * i1;
  const double d2 = M(2, 2) - l20 * M(0, 2) - l21 * m21;
  if (!(d2 > 0.0)) return false;
  const double z0 = b[0];
  const double z1 = b[1] - l10 * z0;
  const double z2 = b[2] - l20 * z0 - l21 * z1;
  x[2] = z2 / d2;
  x[1] = z1 * i1 - l21 * x[2];
  x[0] = z0 * i0 - l10 * x[1] - l20 * x[2];
  return true;
}

}  // namespace dualv::model
