#pragma once
// Small planar helpers shared by the model's algorithms (header-only, inline).
#include <Eigen/Core>
#include <cmath>

namespace dualv::model::planar {

// E v: v rotated by +90 degrees (d/dt Rot(phi) v = phi_dot E Rot(phi) v).
inline Eigen::Vector2d perp(const Eigen::Vector2d& v) noexcept { return {-v.y(), v.x()}; }

// z component of the 3-D cross product a x b.
inline double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) noexcept {
  return a.x() * b.y() - a.y() * b.x();
}

inline Eigen::Vector2d rotate(double angle, const Eigen::Vector2d& v) noexcept {
  const double c = std::cos(angle), s = std::sin(angle);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
}

// Rotates v by the angle of `direction` (|direction| > 0), avoiding atan2.
inline Eigen::Vector2d rotate_along(const Eigen::Vector2d& direction,
                                    const Eigen::Vector2d& v) noexcept {
  const Eigen::Vector2d d = direction.normalized();
  return {d.x() * v.x() - d.y() * v.y(), d.y() * v.x() + d.x() * v.y()};
}

}  // namespace dualv::model::planar
