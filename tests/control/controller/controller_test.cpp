#include "control/controller/controller.hpp"

#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <random>

#include "common/config_error.hpp"
#include "control/config/model_config.hpp"
#include "control/model/dynamics.hpp"
#include "control/model/kinematics.hpp"

namespace dualv::control {
namespace {

model::Model dual_v() {
  return model::load_model_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
}

ControllerConfig gains(int n, bool ff, bool proj) {
  ControllerConfig c;
  c.kp = model::JointVector::Constant(n, 2000.0);
  c.kd = model::JointVector::Constant(n, 20.0);
  c.feedforward = ff;
  c.projection = proj;
  return c;
}

// A reference at X_d with the joint values the model gives there.
trajectory::Reference reference_at(const model::Model& m, const model::Pose& X,
                                   const model::Twist& Xd, const model::Twist& Xdd) {
  trajectory::Reference ref;
  model::Data d(m);
  EXPECT_EQ(model::update_kinematics(m, d, X, Xd), model::Status::kOk);
  ref.cartesian.X = X;
  ref.cartesian.X_dot = Xd;
  ref.cartesian.X_dd = Xdd;
  ref.q = d.q;
  ref.q_dot = d.q_dot;
  model::joint_acceleration(d, Xd, Xdd, ref.q_dd);
  return ref;
}

StateEstimate estimate_at(const model::Model& m, const model::Pose& X, const model::Twist& Xd) {
  StateEstimate est;
  model::Data d(m);
  EXPECT_EQ(model::update_kinematics(m, d, X, Xd), model::Status::kOk);
  est.q = d.q;
  est.q_dot = d.q_dot;
  est.X = X;
  est.X_dot = Xd;
  return est;
}

// Null space of Jm^T from an SVD: independent of the model's projector code.
Eigen::MatrixXd null_space_of_JmT(const model::Model& m, const model::Pose& X) {
  model::Data d(m);
  EXPECT_EQ(model::update_kinematics(m, d, X, model::Twist::Zero()), model::Status::kOk);
  const Eigen::MatrixXd JmT = d.Jm.transpose();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(JmT, Eigen::ComputeFullV);
  return svd.matrixV().rightCols(m.n - 3);
}

TEST(Controller, PdLawWithoutFeedforwardOrProjectionIsKpEPlusKdEdot) {
  const auto m = dual_v();
  Controller c(m, gains(m.n, false, false));
  const auto ref = reference_at(m, m.home, model::Twist(0.1, 0, 0), model::Twist::Zero());
  const auto est = estimate_at(m, m.home + model::Pose(0.001, -0.002, 0.003), model::Twist::Zero());
  ControlOutput out;
  ASSERT_EQ(c.update(ref, est, out), ControlStatus::kOk);
  for (int i = 0; i < m.n; ++i) {
    const double e = ref.q[i] - est.q[i], ed = ref.q_dot[i] - est.q_dot[i];
    EXPECT_NEAR(out.tau[i], 2000.0 * e + 20.0 * ed, 1e-9);
  }
}

TEST(Controller, FeedforwardIsTheInverseDynamicsOfTheReference) {
  const auto m = dual_v();
  Controller c(m, gains(m.n, true, false));
  const model::Pose X = m.home + model::Pose(0.01, 0.0, 0.05);
  const model::Twist Xd(0.2, -0.1, 0.5), Xdd(3.0, 1.0, -10.0);
  const auto ref = reference_at(m, X, Xd, Xdd);
  ControlOutput out;
  ASSERT_EQ(c.update(ref, estimate_at(m, X, Xd), out), ControlStatus::kOk);
  // At zero error the command is the feedforward; it realises X_dd on the model.
  EXPECT_LT(out.tau_pd.norm(), 1e-9);
  model::Data d(m);
  model::Twist a;
  ASSERT_EQ(model::forward_dynamics(m, d, X, Xd, out.tau, a), model::Status::kOk);
  EXPECT_LT((a - Xdd).norm(), 1e-9);
}

TEST(Controller, ProjectionRemovesEveryInternalForceComponent) {
  const auto m = dual_v();
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Controller with(m, gains(m.n, true, true)), without(m, gains(m.n, true, false));
  for (int k = 0; k < 200; ++k) {
    const model::Pose Xd_pose = m.home + model::Pose(0.03 * u(rng), 0.03 * u(rng), 0.1 * u(rng));
    const model::Pose X = Xd_pose + model::Pose(1e-3 * u(rng), 1e-3 * u(rng), 1e-3 * u(rng));
    const auto ref = reference_at(m, Xd_pose, model::Twist(u(rng), u(rng), u(rng)) * 0.1,
                                  model::Twist(u(rng), u(rng), u(rng)));
    const auto est = estimate_at(m, X, model::Twist::Zero());
    ControlOutput a, b;
    ASSERT_EQ(with.update(ref, est, a), ControlStatus::kOk);
    ASSERT_EQ(without.update(ref, est, b), ControlStatus::kOk);
    const Eigen::MatrixXd Nb = null_space_of_JmT(m, X);
    const Eigen::VectorXd tau_a = a.tau, tau_b = b.tau;
    EXPECT_LT((Nb.transpose() * tau_a).norm(), 1e-9);
    EXPECT_GT((Nb.transpose() * tau_b).norm(), 1e-6);  // the PD part fights itself
    // The plate-space force is unchanged by the projection.
    model::Data d(m);
    ASSERT_EQ(model::update_kinematics(m, d, X, model::Twist::Zero()), model::Status::kOk);
    EXPECT_LT((d.Jm.transpose() * (a.tau - b.tau)).norm(), 1e-9 * (1.0 + b.tau.norm()));
  }
}

TEST(Controller, InvalidReferenceCommandsZeroTorque) {
  const auto m = dual_v();
  Controller c(m, gains(m.n, true, true));
  auto ref = reference_at(m, m.home, model::Twist::Zero(), model::Twist::Zero());
  ref.q[2] = NAN;
  ControlOutput out;
  EXPECT_EQ(c.update(ref, estimate_at(m, m.home, model::Twist::Zero()), out),
            ControlStatus::kReferenceInvalid);
  EXPECT_EQ(out.tau.norm(), 0.0);
  ref = reference_at(m, m.home, model::Twist::Zero(), model::Twist::Zero());
  ref.cartesian.X = model::Pose(0, 3, 0);  // feedforward at an unreachable pose
  EXPECT_EQ(c.update(ref, estimate_at(m, m.home, model::Twist::Zero()), out),
            ControlStatus::kModelFailed);
  EXPECT_EQ(out.tau.norm(), 0.0);
}

TEST(ControllerConfig, GainsPerJointOrScalarAndErrorsNamed) {
  auto load = [](const std::string& text) { return load_control_config(YAML::Load(text), 4); };
  const auto s = load("{kp: 1000, kd: [1, 2, 3, 4], velocity_cutoff_hz: 150}");
  EXPECT_EQ(s.controller.kp[3], 1000.0);
  EXPECT_EQ(s.controller.kd[2], 3.0);
  EXPECT_EQ(s.estimator.velocity_cutoff_hz, 150.0);
  EXPECT_TRUE(s.controller.projection);
  auto error = [&](const std::string& text) -> std::string {
    try {
      load(text);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error("{kp: -1, kd: 1}").find("controller.kp: must be in (0, 1000000]"),
            std::string::npos);
  // Issue 14: a physically absurd gain or filter (a unit mistake) is refused with its range.
  EXPECT_NE(error("{kp: 7e9, kd: 1}").find("controller.kp: must be in (0, 1000000]"),
            std::string::npos);
  EXPECT_NE(error("{kp: 1, kd: 1, velocity_cutoff_hz: 1e12}")
                .find("controller.velocity_cutoff_hz: must be in [0.1, 10000]"),
            std::string::npos);
  EXPECT_NE(error("{kp: [1, 2], kd: 1}").find("controller.kp: must be one number or a list of 4"),
            std::string::npos);
  EXPECT_NE(error("{kd: 1}").find("controller.kp: missing"), std::string::npos);
  EXPECT_NE(error("{kp: 1, kd: 1, gain: 3}").find("controller.gain: unknown key"),
            std::string::npos);
  EXPECT_NE(error("{kp: 1, kd: 1, velocity_cutoff_hz: 0}").find("velocity_cutoff_hz: must be in"),
            std::string::npos);
  EXPECT_NE(error("{kp: 1, kd: 1, projection: maybe}")
                .find("controller.projection: must be true or false"),
            std::string::npos);
}

}  // namespace
}  // namespace dualv::control
