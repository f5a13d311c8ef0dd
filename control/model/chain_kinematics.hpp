#pragma once
// One chain's position and velocity closure, written out in scalars (internal to
// control/model): kinematics.cpp loops them over the chains, and update_dynamics fuses them
// with the mass terms, so the plant's RK4 (40 000 evaluations per simulated second) walks
// each chain once.
#include <cmath>

#include "control/model/model.hpp"

namespace dualv::model::detail {

// Below this |sin(crank, coupler)| the chain is treated as serially singular:
// Jm's row would divide by ~0.
inline constexpr double kSerialEpsilon = 1e-9;

// Plate pose as the chains need it: position and (cos, sin) of its angle.
struct PlateFrame {
  double x, y, c, s;
};

// Chain positions at the plate frame: anchor C_i, crank a_i = B_i - A_i, elbow B_i,
// coupler u_i = C_i - B_i, into `cs`. kUnreachable when |C_i - A_i| is outside
// [|l1 - l2|, l1 + l2].
[[gnu::always_inline]] inline Status chain_position(const Chain& ch, const PlateFrame& f,
                                                    ChainState& cs) noexcept {
  const double px = ch.plate_anchor.x(), py = ch.plate_anchor.y();
  const double rx = f.c * px - f.s * py, ry = f.s * px + f.c * py;
  const double cx = f.x + rx, cy = f.y + ry;
  const double dx = cx - ch.base.x(), dy = cy - ch.base.y();
  const double dd = dx * dx + dy * dy;
  if (!(dd > 0.0)) return Status::kUnreachable;
  const double l1 = ch.crank_length, l2 = ch.coupler_length;
  // q_i = atan2(d) + s_i gamma, gamma = acos((l1^2 + |d|^2 - l2^2) / (2 l1 |d|)) in [0, pi]
  // (DESIGN.md). The crank is d rotated by s_i gamma and scaled to l1; as the intersection
  // of the two circles: a = k d + s_i m E d with k = l1 cos(gamma) / |d|
  // = (l1^2 + |d|^2 - l2^2) / (2 |d|^2) and m = l1 sin(gamma) / |d| = sqrt(l1^2 / |d|^2 - k^2):
  // one division and one square root (|d| itself is never needed).
  const double inv_dd = 1.0 / dd;
  const double k = (l1 * l1 - l2 * l2 + dd) * 0.5 * inv_dd;
  const double m2 = l1 * l1 * inv_dd - k * k;  // >= 0 iff |cos(gamma)| <= 1
  if (!(m2 >= 0.0)) return Status::kUnreachable;
  const double m = ch.working_mode * std::sqrt(m2);
  const double ax = k * dx - m * dy, ay = k * dy + m * dx;
  cs.r = Vec2(rx, ry);
  cs.anchor = Vec2(cx, cy);
  cs.crank = Vec2(ax, ay);
  cs.elbow = Vec2(ch.base.x() + ax, ch.base.y() + ay);
  cs.coupler = Vec2(dx - ax, dy - ay);
  return Status::kOk;
}

// Jm's row of the chain, the joint velocity and its acceleration at zero plate
// acceleration (Jm_dot's row times X_dot).
struct ChainVelocity {
  double j0, j1, j2;  // q_dot = j . X_dot
  double inv_den;     // 1 / (a x u)
  double q_dot;
  double qdd_bias;
  // Time derivatives of the row's numerator [u^T, r x u] and denominator a x u (Jm_dot).
  double num_dot0, num_dot1, num_dot2, den_dot;
};

// Closure |C_i - B_i| = l2 differentiated: u . (C_dot - B_dot) = 0 with
// C_dot = p_dot + theta_dot E r and B_dot = q_dot E a, so q_dot = [u^T, r x u] X_dot / (a x u).
// With X_dot = (xd, yd, thd); kSerialSingular when a x u vanishes.
[[gnu::always_inline]] inline Status chain_velocity(const Chain& ch, const ChainState& cs,
                                                    double xd, double yd, double thd,
                                                    ChainVelocity& v) noexcept {
  const double ax = cs.crank.x(), ay = cs.crank.y();
  const double ux = cs.coupler.x(), uy = cs.coupler.y();
  const double rx = cs.r.x(), ry = cs.r.y();
  const double den = ax * uy - ay * ux;
  // |a| = l1 and |u| = l2 by construction: |sin| = |a x u| / (l1 l2), no square roots.
  if (!(std::abs(den) >= kSerialEpsilon * ch.crank_length * ch.coupler_length))
    return Status::kSerialSingular;
  const double inv_den = 1.0 / den;
  const double ru = rx * uy - ry * ux;
  v.inv_den = inv_den;
  v.j0 = ux * inv_den;
  v.j1 = uy * inv_den;
  v.j2 = ru * inv_den;
  const double qd = v.j0 * xd + v.j1 * yd + v.j2 * thd;
  v.q_dot = qd;
  // Time derivative of the row: d(num/den) = (num_dot - row den_dot) / den, applied to
  // X_dot: (num_dot . X_dot - q_dot den_dot) / den.
  const double rdx = -thd * ry, rdy = thd * rx;  // r_dot = theta_dot E r
  const double adx = -qd * ay, ady = qd * ax;    // a_dot = q_dot E a
  const double udx = xd + rdx - adx, udy = yd + rdy - ady;
  v.num_dot0 = udx;
  v.num_dot1 = udy;
  v.num_dot2 = rdx * uy - rdy * ux + rx * udy - ry * udx;
  v.den_dot = adx * uy - ady * ux + ax * udy - ay * udx;
  v.qdd_bias = (udx * xd + udy * yd + v.num_dot2 * thd - qd * v.den_dot) * inv_den;
  return Status::kOk;
}

}  // namespace dualv::model::detail
