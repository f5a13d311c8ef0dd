#pragma once
// Point-to-point moves and dwells (Bennehar et al. 2014, section V: shapes are joined by PtP
// moves along 5th-order polynomials). Header-only, noexcept, allocation-free.
//
// PtP: X(t) = X0 + (X1 - X0) s(u), u = t / T, s(u) = 10u^3 - 15u^4 + 6u^5: a straight line in
// (x, y, theta) with zero velocity and acceleration at both ends (jerk = 60 (X1 - X0) / T^3 at
// the ends). Peak speed 1.875 |X1 - X0| / T at u = 1/2, peak acceleration
// 10 / sqrt(3) |X1 - X0| / T^2 at u = 1/2 -+ sqrt(3)/6.
#include <algorithm>
#include <cmath>

#include "control/trajectory/sample.hpp"

namespace dualv::trajectory {

inline constexpr double kQuinticPeakSpeed = 1.875;                     // max s'(u)
inline constexpr double kQuinticPeakAcceleration = 5.773502691896258;  // max |s''(u)| = 10/sqrt(3)

struct PtpMove {
  Pose start = Pose::Zero();
  Pose end = Pose::Zero();
  double T = 1.0;  // duration [s], > 0

  // t from the move's start; clamped to [0, T] (at rest at the ends; NaN: at the start).
  void sample(double t, CartesianSample& out) const noexcept {
    const double u = t > 0.0 ? (t < T ? t / T : 1.0) : 0.0;  // NaN: at the start
    const double u2 = u * u, u3 = u2 * u;
    const double s = u3 * (10.0 - 15.0 * u + 6.0 * u2);
    const double ds = 30.0 * u2 * (1.0 - 2.0 * u + u2) / T;  // 30u^2 (1 - u)^2
    const double dds = 60.0 * u * (1.0 - 3.0 * u + 2.0 * u2) / (T * T);
    const double ddds = 60.0 * (1.0 - 6.0 * u + 6.0 * u2) / (T * T * T);
    const Twist d = end - start;
    const bool inside = t >= 0.0 && t <= T;
    out.X = start + s * d;
    out.X_dot = ds * d;
    out.X_dd = dds * d;
    out.X_ddd = inside ? Twist(ddds * d) : Twist::Zero();
  }
};

// Holds a pose for T seconds.
struct Dwell {
  Pose pose = Pose::Zero();
  double T = 0.0;  // [s], >= 0

  void sample(double /*t*/, CartesianSample& out) const noexcept {
    out.X = pose;
    out.X_dot.setZero();
    out.X_dd.setZero();
    out.X_ddd.setZero();
  }
};

// Shortest quintic duration [s] whose peak translational speed and acceleration stay within
// the limits (rotation with `angular_*`): T = max(1.875 d / v, sqrt(5.77 d / a)).
inline double ptp_min_duration(const Pose& start, const Pose& end, double max_speed,
                               double max_acceleration, double max_angular_speed,
                               double max_angular_acceleration) noexcept {
  const double d = (end - start).head<2>().norm();
  const double r = std::abs(end[2] - start[2]);
  double T = 0.0;
  if (max_speed > 0.0) T = std::max(T, kQuinticPeakSpeed * d / max_speed);
  if (max_acceleration > 0.0)
    T = std::max(T, std::sqrt(kQuinticPeakAcceleration * d / max_acceleration));
  if (max_angular_speed > 0.0) T = std::max(T, kQuinticPeakSpeed * r / max_angular_speed);
  if (max_angular_acceleration > 0.0)
    T = std::max(T, std::sqrt(kQuinticPeakAcceleration * r / max_angular_acceleration));
  return T;
}

}  // namespace dualv::trajectory
