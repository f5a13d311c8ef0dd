#include "control/model/dynamics.hpp"

#include <cmath>

#include "control/model/kinematics.hpp"
#include "control/model/planar.hpp"
#include "control/model/solve_spd3.hpp"

namespace dualv::model {

using planar::perp;

namespace {

using BodyJacobian = Eigen::Matrix3d;  // rows: com velocity x, y [m/s]; angular velocity [rad/s]

// Velocity Jacobian J_b (body twist = J_b X_dot) and bias acceleration b_b
// (body acceleration = J_b X_dd + b_b) of one rigid body, with its world
// centre of mass.
struct BodyMotion {
  BodyJacobian J;
  Eigen::Vector3d bias;
  Vec2 com;
};

// Visits the 2n + 1 bodies in turn after update_kinematics(X, X_dot).
// The plate's and every link's motion follows from X through the closure of
// each chain; nothing here approximates a coupler by lumped masses.
template <typename Visitor>
void for_each_body(const Model& model, const Data& data, const Pose& X, const Twist& X_dot,
                   Visitor&& visit) noexcept {
  const double th_dot = X_dot.z();
  {
    const Vec2 rc = planar::rotate(X.z(), model.plate.com);
    BodyMotion b;
    b.J << 1.0, 0.0, perp(rc).x(), 0.0, 1.0, perp(rc).y(), 0.0, 0.0, 1.0;
    b.bias << -th_dot * th_dot * rc, 0.0;
    b.com = X.head<2>() + rc;
    visit(model.plate, b);
  }
  for (int i = 0; i < model.n; ++i) {
    const Chain& ch = model.chains[i];
    const ChainState& cs = data.chain[i];
    const Eigen::RowVector3d jm = data.Jm.row(i);
    const double qd = data.q_dot[i];
    const double qdd_bias = data.qdd_bias[i];  // q_dd = jm X_dd + qdd_bias

    // Crank: rotates about A_i with angle q_i.
    const Vec2 rc1 = planar::rotate_along(cs.crank, ch.crank.com);
    BodyMotion crank;
    crank.J.topRows<2>() = perp(rc1) * jm;
    crank.J.row(2) = jm;
    crank.bias << perp(rc1) * qdd_bias - qd * qd * rc1, qdd_bias;
    crank.com = ch.base + rc1;
    visit(ch.crank, crank);

    // Coupler: from elbow B_i to anchor C_i; its angle phi follows u = C_i - B_i:
    // u_dot = phi_dot E u, u_dd = phi_dd E u - phi_dot^2 u.
    const Vec2& u = cs.coupler;
    const double uu = u.squaredNorm();
    Eigen::Matrix<double, 2, 3> JC;  // C_dot = JC X_dot
    JC << 1.0, 0.0, perp(cs.r).x(), 0.0, 1.0, perp(cs.r).y();
    const Eigen::Matrix<double, 2, 3> JB = perp(cs.crank) * jm;  // B_dot = JB X_dot
    const Eigen::RowVector3d Jphi = perp(u).transpose() * (JC - JB) / uu;
    const Vec2 bias_B = perp(cs.crank) * qdd_bias - qd * qd * cs.crank;
    const Vec2 bias_C = -th_dot * th_dot * cs.r;
    const double phi_dot = Jphi.dot(X_dot);
    const double bias_phi = perp(u).dot(bias_C - bias_B) / uu;
    const Vec2 rc2 = planar::rotate_along(u, ch.coupler.com);
    BodyMotion coupler;
    coupler.J.topRows<2>() = JB + perp(rc2) * Jphi;
    coupler.J.row(2) = Jphi;
    coupler.bias << bias_B + bias_phi * perp(rc2) - phi_dot * phi_dot * rc2, bias_phi;
    coupler.com = cs.elbow + rc2;
    visit(ch.coupler, coupler);
  }
}

// One body's share of M, h and g (principle of virtual power), written out for speed:
// M += m Jv^T Jv + I Jw^T Jw (upper triangle), h += m Jv^T bv + I Jw^T bw,
// g -= m Jv^T gravity. Jv (2x3, rows vx, vy): centre-of-mass velocity Jacobian; Jw (1x3):
// angular velocity Jacobian; (bv, bw): bias accelerations.
struct BodyRows {
  Eigen::Vector3d vx, vy, w;
  double bx, by, bw;
};

// Upper triangle of M, h and g as scalars: kept in registers across the bodies (a 3x3
// matrix indexed in loops was stored to memory on every update).
struct Sums {
  double m00 = 0, m01 = 0, m02 = 0, m11 = 0, m12 = 0, m22 = 0;
  double h0 = 0, h1 = 0, h2 = 0, g0 = 0, g1 = 0, g2 = 0;
};

[[gnu::always_inline]] inline void accumulate(const Body& body, const BodyRows& b,
                                              const Vec2& gravity, Sums& S) noexcept {
  const double m = body.mass, I = body.inertia;
  const double ax0 = m * b.vx[0], ax1 = m * b.vx[1], ax2 = m * b.vx[2];  // m Jv^T
  const double ay0 = m * b.vy[0], ay1 = m * b.vy[1], ay2 = m * b.vy[2];
  const double aw0 = I * b.w[0], aw1 = I * b.w[1], aw2 = I * b.w[2];  // I Jw^T
  S.m00 += ax0 * b.vx[0] + ay0 * b.vy[0] + aw0 * b.w[0];
  S.m01 += ax0 * b.vx[1] + ay0 * b.vy[1] + aw0 * b.w[1];
  S.m02 += ax0 * b.vx[2] + ay0 * b.vy[2] + aw0 * b.w[2];
  S.m11 += ax1 * b.vx[1] + ay1 * b.vy[1] + aw1 * b.w[1];
  S.m12 += ax1 * b.vx[2] + ay1 * b.vy[2] + aw1 * b.w[2];
  S.m22 += ax2 * b.vx[2] + ay2 * b.vy[2] + aw2 * b.w[2];
  S.h0 += ax0 * b.bx + ay0 * b.by + aw0 * b.bw;
  S.h1 += ax1 * b.bx + ay1 * b.by + aw1 * b.bw;
  S.h2 += ax2 * b.bx + ay2 * b.by + aw2 * b.bw;
  S.g0 -= ax0 * gravity.x() + ay0 * gravity.y();
  S.g1 -= ax1 * gravity.x() + ay1 * gravity.y();
  S.g2 -= ax2 * gravity.x() + ay2 * gravity.y();
}

// A body turning with angular velocity w X_dot (angular acceleration w X_dd + bias) about a
// fixed axis or its centre of mass, with inertia I about it: M += I w w^T, h += I bias w.
[[gnu::always_inline]] inline void add_rotation(double I, const Eigen::Vector3d& w, double bias,
                                                Sums& S) noexcept {
  const double a0 = I * w[0], a1 = I * w[1], a2 = I * w[2];
  S.m00 += a0 * w[0];
  S.m01 += a0 * w[1];
  S.m02 += a0 * w[2];
  S.m11 += a1 * w[1];
  S.m12 += a1 * w[2];
  S.m22 += a2 * w[2];
  S.h0 += a0 * bias;
  S.h1 += a1 * bias;
  S.h2 += a2 * bias;
}

}  // namespace

ChainInertia chain_inertia(const Chain& ch) noexcept {
  const Body& cr = ch.crank;
  const Body& cp = ch.coupler;
  const double l1 = ch.crank_length, l2 = ch.coupler_length, d = cp.com.x();
  ChainInertia c;
  c.split = cp.com.y() == 0.0;
  if (c.split) {
    c.anchor_mass = cp.mass * (d / l2);
    c.elbow_mass = cp.mass - c.anchor_mass;
    c.coupler_rotary = cp.inertia - cp.mass * d * (l2 - d);
  }
  c.crank_about_axis = cr.inertia + cr.mass * cr.com.squaredNorm() + c.elbow_mass * l1 * l1;
  return c;
}

Status update_dynamics(const Model& model, Data& data, const Pose& X, const Twist& X_dot) noexcept {
  if (const Status s = update_velocity_kinematics(model, data, X, X_dot); s != Status::kOk)
    return s;
  // The same bodies, Jacobians and biases as for_each_body (which the energies still use,
  // an independent check in the tests), in explicit scalar form: this runs 40 000 times
  // per simulated second in the plant's RK4.
  Sums S;
  const Vec2& grav = model.gravity;
  const bool has_gravity = grav.x() != 0.0 || grav.y() != 0.0;  // zero: a horizontal machine
  const double th_dot = X_dot.z();
  {
    // Plate: v = p_dot + theta_dot E rc, omega = theta_dot.
    const Vec2& cs = data.rotation;  // from the kinematics above: no second sin/cos
    const Vec2& pc = model.plate.com;
    const Vec2 rc(cs.x() * pc.x() - cs.y() * pc.y(), cs.y() * pc.x() + cs.x() * pc.y());
    BodyRows b;
    b.vx << 1.0, 0.0, -rc.y();
    b.vy << 0.0, 1.0, rc.x();
    b.w << 0.0, 0.0, 1.0;
    b.bx = -th_dot * th_dot * rc.x();
    b.by = -th_dot * th_dot * rc.y();
    b.bw = 0.0;
    accumulate(model.plate, b, grav, S);
  }
  // Point masses riding on the plate at r_i (the couplers' shares at their anchors, below):
  // sum m, sum m r, sum m |r|^2.
  double pm = 0.0, pm_rr = 0.0;
  Vec2 pm_r = Vec2::Zero();
  for (int i = 0; i < model.n; ++i) {
    const Chain& ch = model.chains[i];
    const ChainState& cs = data.chain[i];
    const Eigen::Vector3d jm = data.Jm.row(i).transpose();
    const double qd = data.q_dot[i];
    const double qdd_bias = data.qdd_bias[i];  // q_dd = jm X_dd + qdd_bias
    const Vec2& a = cs.crank;
    const Vec2& u = cs.coupler;
    const Vec2& r = cs.r;
    const double l1 = ch.crank_length, l2 = ch.coupler_length;
    // |u| = l2 (IK), and C_dot - B_dot = phi_dot E u: phi_dot = Jphi X_dot with
    // Jphi = (E u)^T (C_dot - B_dot) / l2^2 = ((-u_y, u_x, u . r) - (u . a) jm) / l2^2.
    // Divisions bound this loop's speed: one by l2 here (chain_inertia's depend on the model
    // only, so they wait on nothing).
    const double inv_l2 = 1.0 / l2;
    const double inv_uu = inv_l2 * inv_l2;
    const Eigen::Vector3d Jphi =
        (Eigen::Vector3d(-u.y(), u.x(), u.dot(r)) - u.dot(a) * jm) * inv_uu;
    const Vec2 bias_B = perp(a) * qdd_bias - qd * qd * a;
    const Vec2 bias_C = -th_dot * th_dot * r;
    const double bias_phi = perp(u).dot(bias_C - bias_B) * inv_uu;

    // The coupler split into shares at B_i and C_i and a rotary inertia when its centre of
    // mass is on its axis (chain_inertia); off the axis, the general body form below.
    const ChainInertia ci = chain_inertia(ch);
    const double mB = ci.elbow_mass;

    // Crank (+ the coupler's share at B_i): a pure rotation about A_i, so its share
    // collapses to the inertia about the axis I_A: M += I_A jm jm^T, h += I_A qdd_bias jm
    // (the centripetal terms are orthogonal to E rc and E a), g -= (m E rc + mB E a) .
    // gravity jm.
    add_rotation(ci.crank_about_axis, jm, qdd_bias, S);
    if (has_gravity) {
      const Vec2 dir = a / l1;  // |a| = l1 (IK)
      const Vec2 rc1(dir.x() * ch.crank.com.x() - dir.y() * ch.crank.com.y(),
                     dir.y() * ch.crank.com.x() + dir.x() * ch.crank.com.y());
      const double wg = (ch.crank.mass * perp(rc1) + mB * perp(a)).dot(grav);
      S.g0 -= wg * jm[0];
      S.g1 -= wg * jm[1];
      S.g2 -= wg * jm[2];
    }

    if (ci.split) {
      const double mC = ci.anchor_mass;
      pm += mC;
      pm_r += mC * r;
      pm_rr += mC * ch.plate_anchor.squaredNorm();  // |r| = |c_i|
      // Rotary share: M += J Jphi Jphi^T, h += J bias_phi Jphi (no gravity: no mass).
      add_rotation(ci.coupler_rotary, Jphi, bias_phi, S);
      continue;
    }
    // General coupler: angle phi of u = C_i - B_i, centre of mass rc2 from B_i.
    const double phi_dot = Jphi.dot(X_dot);
    const Vec2 udir = u * inv_l2;
    const Vec2 rc2(udir.x() * ch.coupler.com.x() - udir.y() * ch.coupler.com.y(),
                   udir.y() * ch.coupler.com.x() + udir.x() * ch.coupler.com.y());
    BodyRows b;
    // Centre of mass velocity: B_dot + phi_dot E rc2, B_dot = qd E a.
    b.vx = -a.y() * jm - rc2.y() * Jphi;
    b.vy = a.x() * jm + rc2.x() * Jphi;
    b.w = Jphi;
    const Vec2 bv = bias_B + bias_phi * perp(rc2) - phi_dot * phi_dot * rc2;
    b.bx = bv.x();
    b.by = bv.y();
    b.bw = bias_phi;
    accumulate(ch.coupler, b, grav, S);
  }
  // The point masses on the plate: v = p_dot + theta_dot E r, bias -theta_dot^2 r.
  S.m00 += pm;
  S.m11 += pm;
  S.m02 -= pm_r.y();
  S.m12 += pm_r.x();
  S.m22 += pm_rr;
  S.h0 -= th_dot * th_dot * pm_r.x();
  S.h1 -= th_dot * th_dot * pm_r.y();
  S.g0 -= pm * grav.x();
  S.g1 -= pm * grav.y();
  S.g2 -= perp(pm_r).dot(grav);
  data.M << S.m00, S.m01, S.m02, S.m01, S.m11, S.m12, S.m02, S.m12, S.m22;
  data.h << S.h0, S.h1, S.h2;
  data.g << S.g0, S.g1, S.g2;
  return Status::kOk;
}

Status generalized_force(const Model& model, Data& data, const Pose& X, const Twist& X_dot,
                         const Twist& X_dd, Twist& F) noexcept {
  if (!X_dd.allFinite()) return Status::kInvalidInput;
  if (const Status s = update_dynamics(model, data, X, X_dot); s != Status::kOk) return s;
  F.noalias() = data.M * X_dd;
  F += data.h + data.g;
  return Status::kOk;
}

Status inverse_dynamics(const Model& model, Data& data, const Pose& X, const Twist& X_dot,
                        const Twist& X_dd, JointVector& tau) noexcept {
  Twist F;
  if (const Status s = generalized_force(model, data, X, X_dot, X_dd, F); s != Status::kOk)
    return s;
  // Paper eq. 3: tau = Jm^{T*} F_X = Jm (Jm^T Jm)^-1 F_X, by a solve instead of the projectors.
  Ldlt3 ldlt;
  if (!ldlt.factor(data.Jm.transpose() * data.Jm, kParallelSingularTolerance))
    return Status::kParallelSingular;
  Twist y;
  ldlt.solve(F, y);
  tau.resize(model.n);
  tau.noalias() = data.Jm * y;
  return Status::kOk;
}

Status forward_dynamics(const Model& model, Data& data, const Pose& X, const Twist& X_dot,
                        const JointVector& tau, Twist& X_dd) noexcept {
  if (tau.size() != model.n || !tau.allFinite()) return Status::kInvalidInput;
  if (const Status s = update_dynamics(model, data, X, X_dot); s != Status::kOk) return s;
  const Twist F = data.Jm.transpose() * tau;  // virtual power: F_X = Jm^T tau
  if (!solve_spd3(data.M, F - data.h - data.g, X_dd)) return Status::kParallelSingular;
  return Status::kOk;
}

double kinetic_energy(const Model& model, Data& data, const Pose& X, const Twist& X_dot) noexcept {
  if (update_velocity_kinematics(model, data, X, X_dot) != Status::kOk) return 0.0;
  double T = 0.0;
  for_each_body(model, data, X, X_dot, [&](const Body& body, const BodyMotion& b) {
    const Eigen::Vector3d v = b.J * X_dot;
    T += 0.5 * (body.mass * v.head<2>().squaredNorm() + body.inertia * v.z() * v.z());
  });
  return T;
}

double potential_energy(const Model& model, Data& data, const Pose& X) noexcept {
  if (update_velocity_kinematics(model, data, X, Twist::Zero()) != Status::kOk) return 0.0;
  double V = 0.0;
  for_each_body(model, data, X, Twist::Zero(), [&](const Body& body, const BodyMotion& b) {
    V -= body.mass * model.gravity.dot(b.com);
  });
  return V;
}

}  // namespace dualv::model
