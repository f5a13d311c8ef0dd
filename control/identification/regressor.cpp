#include "control/identification/regressor.hpp"

#include "control/model/kinematics.hpp"
#include "control/model/planar.hpp"

namespace dualv::identification {

namespace {

using model::Vec2;
using model::planar::cross;
using model::planar::perp;
using Row3 = Eigen::RowVector3d;
using Jac2 = Eigen::Matrix<double, 2, 3>;

// The motion of one body's link frame: origin velocity J_O X_dot, origin acceleration
// J_O X_dd + b_O, angle rate J_psi X_dot, angular acceleration J_psi X_dd + b_psi, and the
// frame's x axis d (unit vector, world).
struct FrameMotion {
  Jac2 J_O = Jac2::Zero();
  Vec2 b_O = Vec2::Zero();
  Row3 J_psi = Row3::Zero();
  double b_psi = 0.0;
  Vec2 d = Vec2(1.0, 0.0);
};

// The four columns (ZZ, MX, MY, M) of one body, starting at column `first`.
void body_columns(const FrameMotion& fm, const model::Twist& X_dot, const model::Twist& X_dd,
                  const Vec2& gravity, RegressorRows& W, int first) noexcept {
  const Vec2 a_eff = fm.J_O * X_dd + fm.b_O - gravity;  // a_O - g
  const double w = fm.J_psi.dot(X_dot);
  const double alpha = fm.J_psi.dot(X_dd) + fm.b_psi;
  const Vec2 d = fm.d, e = perp(d);
  const auto column = [&](const Vec2& f, double n_O) -> Eigen::Vector3d {
    return fm.J_O.transpose() * f + fm.J_psi.transpose() * n_O;
  };
  W.col(first + static_cast<int>(BodyParameter::kZZ)) = column(Vec2::Zero(), alpha);
  W.col(first + static_cast<int>(BodyParameter::kMX)) =
      column(alpha * perp(d) - w * w * d, cross(d, a_eff));
  W.col(first + static_cast<int>(BodyParameter::kMY)) =
      column(alpha * perp(e) - w * w * e, cross(e, a_eff));
  W.col(first + static_cast<int>(BodyParameter::kM)) = column(a_eff, 0.0);
}

}  // namespace

model::Status regressor(const model::Model& model, model::Data& data, const model::Pose& X,
                        const model::Twist& X_dot, const model::Twist& X_dd,
                        RegressorRows& W) noexcept {
  if (!X_dd.allFinite()) return model::Status::kInvalidInput;
  if (const model::Status s = model::update_velocity_kinematics(model, data, X, X_dot);
      s != model::Status::kOk)
    return s;
  const ParameterLayout L{model.n};
  W.setZero(3, L.size());
  const double th_dot = X_dot.z();

  // Plate: origin p, angle theta.
  {
    FrameMotion fm;
    fm.J_O << 1.0, 0.0, 0.0, 0.0, 1.0, 0.0;
    fm.J_psi << 0.0, 0.0, 1.0;
    fm.d = data.rotation;
    body_columns(fm, X_dot, X_dd, model.gravity, W, L.plate(BodyParameter::kZZ));
  }
  for (int i = 0; i < model.n; ++i) {
    const model::Chain& ch = model.chains[i];
    const model::ChainState& cs = data.chain[i];
    const Row3 jm = data.Jm.row(i);
    const double qd = data.q_dot[i];
    const double qdd_bias = data.qdd_bias[i];  // q_dd = jm X_dd + qdd_bias
    const Vec2& a = cs.crank;                  // B_i - A_i
    const Vec2& u = cs.coupler;                // C_i - B_i

    // Crank: origin A_i (fixed), angle q_i.
    FrameMotion crank;
    crank.J_psi = jm;
    crank.b_psi = qdd_bias;
    crank.d = a / ch.crank_length;
    body_columns(crank, X_dot, X_dd, model.gravity, W, L.crank(i, BodyParameter::kZZ));

    // Coupler: origin B_i (B_dot = q_dot E a), angle phi of u. C_i = p + r moves with the
    // plate, and C_dot - B_dot = phi_dot E u gives phi_dot = (E u) . (C_dot - B_dot) / |u|^2.
    FrameMotion coupler;
    coupler.J_O = perp(a) * jm;
    coupler.b_O = perp(a) * qdd_bias - qd * qd * a;
    Jac2 JC;
    JC << 1.0, 0.0, perp(cs.r).x(), 0.0, 1.0, perp(cs.r).y();
    const double uu = u.squaredNorm();
    coupler.J_psi = perp(u).transpose() * (JC - coupler.J_O) / uu;
    const Vec2 bias_C = -th_dot * th_dot * cs.r;
    coupler.b_psi = perp(u).dot(bias_C - coupler.b_O) / uu;
    coupler.d = u / std::sqrt(uu);
    body_columns(coupler, X_dot, X_dd, model.gravity, W, L.coupler(i, BodyParameter::kZZ));

    // Joint friction, mapped to the plate by virtual power: F_X += Jm_i^T tau_f,i.
    W.col(L.viscous(i)) = jm.transpose() * qd;
    W.col(L.coulomb(i)) = jm.transpose() * static_cast<double>((qd > 0.0) - (qd < 0.0));
  }
  return model::Status::kOk;
}

}  // namespace dualv::identification
