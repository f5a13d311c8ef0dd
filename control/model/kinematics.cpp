#include "control/model/kinematics.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "control/model/planar.hpp"
#include "control/model/solve_spd3.hpp"

namespace dualv::model {

using planar::cross;
using planar::perp;

namespace {

bool finite(const Eigen::Vector3d& v) noexcept { return v.allFinite(); }

// Pseudo-angle of v: strictly increasing with atan2(v.y, v.x) over (-pi, pi] (signed zeros
// included), range (-2, 2], no transcendental call. Angles pi apart differ by exactly 2.
double pseudo_angle(const Vec2& v) noexcept {
  return std::copysign(1.0 - v.x() / (std::abs(v.x()) + std::abs(v.y())), v.y());
}

// Chain positions at X: plate anchors, cranks, elbows, couplers (no joint angles: no atan2).
Status chain_geometry(const Model& model, Data& data, const Pose& X) noexcept {
  if (!finite(X) || model.n < 3 || model.n > kMaxChains) return Status::kInvalidInput;
  const Vec2 p = X.head<2>();
  // One sine/cosine of theta for all chains (speed: this runs 4 times per RK4 step).
  const double c = std::cos(X.z()), s = std::sin(X.z());
  data.rotation = Vec2(c, s);
  for (int i = 0; i < model.n; ++i) {
    const Chain& ch = model.chains[i];
    ChainState& cs = data.chain[i];
    const Vec2& pa = ch.plate_anchor;
    cs.r = Vec2(c * pa.x() - s * pa.y(), s * pa.x() + c * pa.y());
    cs.anchor = p + cs.r;
    const Vec2 d = cs.anchor - ch.base;
    const double dd = d.squaredNorm();
    const double l1 = ch.crank_length, l2 = ch.coupler_length;
    if (!(dd > 0.0)) return Status::kUnreachable;
    // q_i = atan2(d) + s_i gamma, gamma = acos((l1^2 + |d|^2 - l2^2) / (2 l1 |d|)) in [0, pi]
    // (docs/architecture.md). The crank is d rotated by s_i gamma and scaled to l1; as the
    // intersection of the two circles: a = k d + s_i m E d with k = l1 cos(gamma) / |d| = (l1^2 +
    // |d|^2 - l2^2) / (2 |d|^2) and m = l1 sin(gamma) / |d| = sqrt(l1^2 / |d|^2 - k^2): one
    // division and one square root (|d| itself is never needed).
    const double inv_dd = 1.0 / dd;
    const double k = (l1 * l1 + dd - l2 * l2) * 0.5 * inv_dd;
    const double m2 = l1 * l1 * inv_dd - k * k;  // >= 0 iff |cos(gamma)| <= 1
    if (!(m2 >= 0.0)) return Status::kUnreachable;
    const double m = ch.working_mode * std::sqrt(m2);
    cs.crank = k * d + m * perp(d);
    cs.elbow = ch.base + cs.crank;
    cs.coupler = cs.anchor - cs.elbow;
  }
  return Status::kOk;
}

// Joint angles from the chain geometry.
void joint_angles(const Model& model, const Data& data, JointVector& q) noexcept {
  q.resize(model.n);
  for (int i = 0; i < model.n; ++i) {
    const ChainState& cs = data.chain[i];
    const Vec2 d = cs.anchor - model.chains[i].base;
    // One atan2 gives q modulo 2 pi; keep the branch of atan2(d) + s_i gamma, which lies in
    // (-2 pi, 2 pi]: it passed the atan2 cut iff the crank's angle is below (s_i = +1) or
    // above (s_i = -1) the angle of d, i.e. by at least pi (pseudo-angles differ by >= 2).
    double qi = std::atan2(cs.crank.y(), cs.crank.x());
    const double dp = pseudo_angle(cs.crank) - pseudo_angle(d);
    const int mode = model.chains[i].working_mode;
    if (mode > 0 && dp < -1.0) qi += 2.0 * M_PI;
    if (mode < 0 && dp > 1.0) qi -= 2.0 * M_PI;
    q[i] = qi;
  }
}

// What jacobian() computes beyond Jm.
enum class Parts : std::uint8_t {
  kJm,          // Jm only (forward kinematics)
  kVelocities,  // + q_dot = Jm X_dot and qdd_bias = Jm_dot X_dot (dynamics)
  kAll,         // + the rows of Jm_dot
};

template <Parts P>
Status jacobian(const Model& model, Data& data, const Twist& X_dot) noexcept {
  if (!finite(X_dot)) return Status::kInvalidInput;
  data.Jm.resize(model.n, 3);
  if constexpr (P != Parts::kJm) {
    data.q_dot.resize(model.n);
    data.qdd_bias.resize(model.n);
  }
  if constexpr (P == Parts::kAll) data.Jm_dot.resize(model.n, 3);
  for (int i = 0; i < model.n; ++i) {
    const ChainState& cs = data.chain[i];
    const Vec2& a = cs.crank;
    const Vec2& u = cs.coupler;
    const Vec2& r = cs.r;
    // Closure |C_i - B_i| = l2 differentiated: u . (C_dot - B_dot) = 0 with
    // C_dot = p_dot + theta_dot E r and B_dot = q_dot E a, so
    // q_dot = [u^T, r x u] X_dot / (a x u).
    const double den = cross(a, u);
    // |a| = l1 and |u| = l2 by construction (IK): no square roots needed.
    const double l1l2 = model.chains[i].crank_length * model.chains[i].coupler_length;
    if (!(std::abs(den) >= kSerialSingularTolerance * l1l2)) return Status::kSerialSingular;
    const Eigen::RowVector3d num(u.x(), u.y(), cross(r, u));
    const double inv_den = 1.0 / den;
    const Eigen::RowVector3d row = num * inv_den;
    data.Jm.row(i) = row;
    if constexpr (P != Parts::kJm) {
      const double qd = row.dot(X_dot);
      data.q_dot[i] = qd;
      // Time derivative of the row: d(num/den) = (num_dot - row den_dot) / den.
      const Vec2 r_dot = X_dot.z() * perp(r);
      const Vec2 a_dot = qd * perp(a);
      const Vec2 u_dot = X_dot.head<2>() + r_dot - a_dot;
      const Eigen::RowVector3d num_dot(u_dot.x(), u_dot.y(), cross(r_dot, u) + cross(r, u_dot));
      const double den_dot = cross(a_dot, u) + cross(a, u_dot);
      if constexpr (P == Parts::kAll) {
        const Eigen::RowVector3d row_dot = (num_dot - row * den_dot) * inv_den;
        data.Jm_dot.row(i) = row_dot;
        data.qdd_bias[i] = row_dot.dot(X_dot);
      } else {  // the same, without the row: (num_dot X_dot - q_dot den_dot) / den
        data.qdd_bias[i] = (num_dot.dot(X_dot) - qd * den_dot) * inv_den;
      }
    }
  }
  return Status::kOk;
}

// atan2(y, x) for x > 0 and |y| <= 0.01 x by its Taylor series (truncation below 1e-17 of
// the result), std::atan2 otherwise: near convergence the forward kinematics' residual
// angles are all tiny, and std::atan2 was a third of its cost.
double small_angle_atan2(double y, double x) noexcept {
  if (x > 0.0 && std::abs(y) <= 0.01 * x) {
    const double t = y / x, t2 = t * t;
    return t * (1.0 - t2 * (1.0 / 3.0 - t2 * (1.0 / 5.0 - t2 * (1.0 / 7.0))));
  }
  return std::atan2(y, x);
}

}  // namespace

Status inverse_kinematics(const Model& model, Data& data, const Pose& X, JointVector& q) noexcept {
  if (const Status s = chain_geometry(model, data, X); s != Status::kOk) return s;
  joint_angles(model, data, q);
  return Status::kOk;
}

Status update_kinematics(const Model& model, Data& data, const Pose& X,
                         const Twist& X_dot) noexcept {
  if (!finite(X_dot)) return Status::kInvalidInput;
  if (const Status s = inverse_kinematics(model, data, X, data.q); s != Status::kOk) return s;
  return jacobian<Parts::kAll>(model, data, X_dot);
}

Status update_velocity_kinematics(const Model& model, Data& data, const Pose& X,
                                  const Twist& X_dot) noexcept {
  if (!finite(X_dot)) return Status::kInvalidInput;
  if (const Status s = chain_geometry(model, data, X); s != Status::kOk) return s;
  return jacobian<Parts::kVelocities>(model, data, X_dot);
}

void joint_acceleration(const Data& data, const Twist& X_dot, const Twist& X_dd,
                        JointVector& q_dd) noexcept {
  q_dd.resize(data.n);
  q_dd.noalias() = data.Jm * X_dd;
  q_dd.noalias() += data.Jm_dot * X_dot;
}

FkResult forward_kinematics(const Model& model, Data& data, const JointVector& q, const Pose& seed,
                            Pose& X, const FkOptions& options) noexcept {
  FkResult result;
  X = seed;
  if (q.size() != model.n || !q.allFinite() || !finite(seed)) {
    result.status = Status::kInvalidInput;
    return result;
  }
  // Gauss-Newton on the joint residual e = q - q_ik(X): X += (Jm^T Jm)^-1 Jm^T e. With n > 3
  // chains and measured (quantised) q the equations are inconsistent: the iteration then
  // converges to the least-squares pose, where the step vanishes but the residual does not.
  // A step that leaves the workspace or does not reduce |e| is halved.
  // e_i is the angle from the model's crank vector a_i(X) to the measured crank direction
  // m_i = (cos q_i, sin q_i): wrapped by construction, and no joint angle (atan2) of the
  // model is needed, only its geometry.
  std::array<Vec2, kMaxChains> measured;
  for (int i = 0; i < model.n; ++i) measured[i] = Vec2(std::cos(q[i]), std::sin(q[i]));
  Pose x = seed;
  JointVector e(model.n);
  auto residual = [&](const Pose& pose, double& norm) -> Status {
    if (const Status s = chain_geometry(model, data, pose); s != Status::kOk) return s;
    for (int i = 0; i < model.n; ++i) {
      const Vec2& a = data.chain[i].crank;
      e[i] = small_angle_atan2(cross(a, measured[i]), a.dot(measured[i]));
    }
    norm = e.norm();
    return Status::kOk;
  };
  double norm = 0.0;
  if (const Status s = residual(x, norm); s != Status::kOk) {
    result.status = s;
    return result;
  }
  bool converged = false;
  bool jm_at_x = false;  // data.Jm evaluated at x
  for (int it = 1; it <= options.max_iterations && !converged; ++it) {
    result.iterations = it;
    if (norm <= options.tolerance) {
      converged = true;
      break;
    }
    const Status js = jacobian<Parts::kJm>(model, data, Twist::Zero());
    Ldlt3 ldlt;
    if (js != Status::kOk ||
        !ldlt.factor(data.Jm.transpose() * data.Jm, kParallelSingularTolerance)) {
      result.status = js != Status::kOk ? js : Status::kParallelSingular;
      result.residual = norm;
      return result;
    }
    jm_at_x = true;
    Twist step;
    ldlt.solve(data.Jm.transpose() * e, step);
    const double step_size = step.cwiseAbs().maxCoeff();
    // Least-squares optimum (or round-off floor) reached: the step no longer moves X.
    if (step_size < options.step_tolerance) {
      converged = true;
      break;
    }
    jm_at_x = false;
    const Pose x_prev = x;
    const double norm_prev = norm;
    double alpha = 1.0;
    bool improved = false;
    for (int halvings = 0; halvings < 30 && !improved; ++halvings, alpha *= 0.5) {
      double trial = 0.0;
      if (residual(x_prev + alpha * step, trial) == Status::kOk && trial < norm_prev) {
        x = x_prev + alpha * step;
        norm = trial;
        improved = true;
      }
    }
    // No step length reduces |e| (round-off floor): converged if the step was small.
    if (!improved) {
      converged = step_size < 1e3 * options.step_tolerance;
      residual(x_prev, norm);
      x = x_prev;
      break;
    }
  }
  // The last residual taken was at x: data.chain and e are at x. Complete `data` there (at
  // rest): Jm, and q on the measured angles' branch (q_ik = q - e).
  result.residual = norm;
  const Status js =
      converged && !jm_at_x ? jacobian<Parts::kJm>(model, data, Twist::Zero()) : Status::kOk;
  result.status = !converged                    ? Status::kNotConverged
                  : js != Status::kOk           ? js
                  : norm > options.max_residual ? Status::kInconsistent
                                                : Status::kOk;
  if (result.status == Status::kOk) {
    X = x;
    data.q = q - e;
    data.q_dot.setZero(model.n);
    data.qdd_bias.setZero(model.n);
    data.Jm_dot.setZero(model.n, 3);
  }
  return result;
}

Status update_projectors(const Model& model, Data& data) noexcept {
  Ldlt3 ldlt;
  if (!ldlt.factor(data.Jm.transpose() * data.Jm, kParallelSingularTolerance))
    return Status::kParallelSingular;
  data.JmT_pinv.resize(model.n, 3);
  data.JmT_pinv.noalias() = data.Jm * ldlt.inverse();
  data.R.resize(model.n, model.n);
  data.R.noalias() = data.JmT_pinv * data.Jm.transpose();
  data.N = JointMatrix::Identity(model.n, model.n) - data.R;
  return Status::kOk;
}

SingularityMeasures singularity_measures(const Model& model, const Data& data) noexcept {
  SingularityMeasures m;
  JointJacobian scaled = data.Jm;
  scaled.col(2) /= model.characteristic_length;
  const Mat3 JtJ = scaled.transpose() * scaled;
  // Closed form for 3x3 (the safety filter evaluates this every cycle); its absolute error,
  // ~1e-15 of the largest eigenvalue, is far below any useful singularity threshold.
  Eigen::SelfAdjointEigenSolver<Mat3> eig;
  eig.computeDirect(JtJ, Eigen::EigenvaluesOnly);
  m.parallel = std::sqrt(std::max(0.0, eig.eigenvalues()[0]));
  m.min_serial = 1.0;
  for (int i = 0; i < model.n; ++i) {
    const ChainState& cs = data.chain[i];
    m.serial[i] = std::abs(cross(cs.crank, cs.coupler)) / (cs.crank.norm() * cs.coupler.norm());
    m.min_serial = std::min(m.min_serial, m.serial[i]);
  }
  return m;
}

Eigen::Vector3d jacobian_singular_values(const Data& data) noexcept {
  const Mat3 JtJ = data.Jm.transpose() * data.Jm;
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(JtJ, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d ev = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();  // ascending
  return {ev[2], ev[1], ev[0]};
}

}  // namespace dualv::model
