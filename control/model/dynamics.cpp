#include "control/model/dynamics.hpp"

#include <Eigen/Cholesky>

#include "control/model/kinematics.hpp"
#include "control/model/planar.hpp"

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
    const double qdd_bias = data.Jm_dot.row(i).dot(X_dot);  // q_dd = jm X_dd + qdd_bias

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

}  // namespace

Status update_dynamics(const Model& model, Data& data, const Pose& X, const Twist& X_dot) noexcept {
  if (const Status s = update_kinematics(model, data, X, X_dot); s != Status::kOk) return s;
  data.M.setZero();
  data.h.setZero();
  data.g.setZero();
  // Principle of virtual power: M = sum J_b^T M_b J_b, h = sum J_b^T M_b b_b,
  // g = -sum J_b^T (m_b gravity, 0).
  for_each_body(model, data, X, X_dot, [&](const Body& body, const BodyMotion& b) {
    const Eigen::Vector3d mass_diag(body.mass, body.mass, body.inertia);
    data.M.noalias() += b.J.transpose() * mass_diag.asDiagonal() * b.J;
    data.h.noalias() += b.J.transpose() * mass_diag.cwiseProduct(b.bias);
    const Eigen::Vector3d weight(body.mass * model.gravity.x(), body.mass * model.gravity.y(), 0.0);
    data.g.noalias() -= b.J.transpose() * weight;
  });
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
  if (const Status s = update_projectors(model, data); s != Status::kOk) return s;
  tau.resize(model.n);
  tau.noalias() = data.JmT_pinv * F;  // paper eq. 3: tau = Jm^{T*} F_X
  return Status::kOk;
}

Status forward_dynamics(const Model& model, Data& data, const Pose& X, const Twist& X_dot,
                        const JointVector& tau, Twist& X_dd) noexcept {
  if (tau.size() != model.n || !tau.allFinite()) return Status::kInvalidInput;
  if (const Status s = update_dynamics(model, data, X, X_dot); s != Status::kOk) return s;
  const Eigen::LLT<Mat3> llt(data.M);
  if (llt.info() != Eigen::Success) return Status::kParallelSingular;
  const Twist F = data.Jm.transpose() * tau;  // virtual power: F_X = Jm^T tau
  X_dd = llt.solve(F - data.h - data.g);
  return Status::kOk;
}

double kinetic_energy(const Model& model, Data& data, const Pose& X, const Twist& X_dot) noexcept {
  if (update_kinematics(model, data, X, X_dot) != Status::kOk) return 0.0;
  double T = 0.0;
  for_each_body(model, data, X, X_dot, [&](const Body& body, const BodyMotion& b) {
    const Eigen::Vector3d v = b.J * X_dot;
    T += 0.5 * (body.mass * v.head<2>().squaredNorm() + body.inertia * v.z() * v.z());
  });
  return T;
}

double potential_energy(const Model& model, Data& data, const Pose& X) noexcept {
  if (update_kinematics(model, data, X, Twist::Zero()) != Status::kOk) return 0.0;
  double V = 0.0;
  for_each_body(model, data, X, Twist::Zero(), [&](const Body& body, const BodyMotion& b) {
    V -= body.mass * model.gravity.dot(b.com);
  });
  return V;
}

}  // namespace dualv::model
