// W(X, X_dot, X_dd) phi against independent implementations: the model's own inverse dynamics
// (control/model/dynamics.cpp: virtual power with the couplers split into point masses) and
// the simulated plant's right-hand side with its joint friction (sim/plant.cpp).
#include "control/identification/regressor.hpp"

#include <gtest/gtest.h>

#include <random>

#include "control/config/model_config.hpp"
#include "control/model/dynamics.hpp"
#include "control/model/kinematics.hpp"
#include "sim/plant.hpp"

namespace dualv::identification {
namespace {

model::Model dual_v() {
  return model::load_model_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
}

struct State {
  model::Pose X;
  model::Twist X_dot, X_dd;
};

State random_state(const model::Model& m, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  State s;
  s.X = m.home + model::Pose(0.08 * u(rng), 0.08 * u(rng), 0.3 * u(rng));
  s.X_dot = model::Twist(0.4 * u(rng), 0.4 * u(rng), 2.0 * u(rng));
  s.X_dd = model::Twist(8.0 * u(rng), 8.0 * u(rng), 50.0 * u(rng));
  return s;
}

// Every term switched on: gravity in the plane, centres of mass off the links' axes (the
// model's general coupler form), a plate centre of mass away from p, bodies that differ chain
// by chain.
model::Model general_model() {
  model::Model m = dual_v();
  m.gravity = model::Vec2(1.3, -9.81);
  m.plate.com = model::Vec2(0.013, -0.007);
  for (int i = 0; i < m.n; ++i) {
    m.chains[i].crank.com = model::Vec2(0.12 + 0.01 * i, 0.004 * (i - 1.5));
    m.chains[i].crank.mass *= 1.0 + 0.05 * i;
    m.chains[i].coupler.com = model::Vec2(0.15 - 0.01 * i, 0.003 * (i % 2 == 0 ? 1 : -1));
    m.chains[i].coupler.inertia *= 1.0 - 0.04 * i;
  }
  return m;
}

double relative_error(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return (a - b).norm() / std::max(1.0, b.norm());
}

void expect_matches_generalized_force(const model::Model& m) {
  model::Data data(m), data2(m);
  const Eigen::VectorXd phi = standard_parameters(m, JointFriction{});  // no friction
  std::mt19937_64 rng(7);
  RegressorRows W;
  int checked = 0;
  for (int k = 0; k < 300; ++k) {
    const State s = random_state(m, rng);
    model::Twist F;
    if (model::generalized_force(m, data2, s.X, s.X_dot, s.X_dd, F) != model::Status::kOk) continue;
    ASSERT_EQ(regressor(m, data, s.X, s.X_dot, s.X_dd, W), model::Status::kOk);
    const Eigen::Vector3d Wphi = W * phi;
    EXPECT_LT(relative_error(Wphi, F), 1e-9)
        << "state " << k << ": W phi " << Wphi.transpose() << " vs F_X " << F.transpose();
    // The actuated projection of the minimum-norm torques: Jm^T tau = F_X = W phi.
    model::JointVector tau;
    ASSERT_EQ(model::inverse_dynamics(m, data2, s.X, s.X_dot, s.X_dd, tau), model::Status::kOk);
    const Eigen::Vector3d JmT_tau = data2.Jm.transpose() * tau;
    EXPECT_LT(relative_error(Wphi, JmT_tau), 1e-9) << "state " << k;
    ++checked;
  }
  EXPECT_GT(checked, 250);
}

TEST(Regressor, TimesStandardParametersIsTheModelsGeneralizedForceOnTheDualV) {
  expect_matches_generalized_force(dual_v());
}

TEST(Regressor, TimesStandardParametersIsTheModelsGeneralizedForceWithGravityAndOffsetCentres) {
  expect_matches_generalized_force(general_model());
}

TEST(Regressor, IsLinearInTheParameters) {
  // Two models' sum: W (phi_a + phi_b) = F_a + F_b, the dynamics of bodies with summed
  // parameters (the regressor must not depend on the parameters themselves).
  const model::Model a = dual_v(), g = general_model();
  model::Data data(a);
  std::mt19937_64 rng(3);
  const State s = random_state(a, rng);
  RegressorRows W;
  ASSERT_EQ(regressor(a, data, s.X, s.X_dot, s.X_dd, W), model::Status::kOk);
  model::Model a0 = a;  // the same geometry, gravity of g
  a0.gravity = g.gravity;
  RegressorRows Wg;
  ASSERT_EQ(regressor(a0, data, s.X, s.X_dot, s.X_dd, Wg), model::Status::kOk);
  const Eigen::VectorXd sum = standard_parameters(a0, {}) + standard_parameters(g, {});
  const model::Model summed = model_with_parameters(a0, sum);
  model::Twist F;
  ASSERT_EQ(model::generalized_force(summed, data, s.X, s.X_dot, s.X_dd, F), model::Status::kOk);
  EXPECT_LT(relative_error(Wg * sum, F), 1e-9);
}

TEST(Regressor, WithFrictionIsTheActuatedProjectionOfThePlantsMotorTorques) {
  // The plant with a mismatched true model and joint friction: random motor torques produce a
  // plate acceleration (the plant's RK4 right-hand side); the regressor at that motion, with
  // the true model's parameters and the plant's friction, must give back Jm^T tau_motor.
  sim::PlantConfig cfg = sim::PlantConfig::ideal();
  cfg.mismatch.enabled = true;
  cfg.mismatch.crank = {12.0, -8.0};
  cfg.mismatch.coupler = {-15.0, 20.0};
  cfg.mismatch.plate = {18.0, -11.0};
  cfg.friction.enabled = true;
  cfg.friction.coulomb = 0.7;
  cfg.friction.viscous = 0.09;
  const model::Model nominal = dual_v();
  sim::Plant plant(nominal, cfg);
  const model::Model& truth = plant.true_model();
  const Eigen::VectorXd phi =
      standard_parameters(truth, JointFriction{cfg.friction.viscous, cfg.friction.coulomb});
  model::Data data(truth);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> torque(-20.0, 20.0);
  RegressorRows W;
  int checked = 0;
  for (int k = 0; k < 200; ++k) {
    const State s = random_state(truth, rng);
    if (model::update_velocity_kinematics(truth, data, s.X, s.X_dot) != model::Status::kOk)
      continue;
    // Every joint faster than the smoothing velocity: the plant's Coulomb term is then exactly
    // coulomb sign(q_dot).
    if ((data.q_dot.array().abs() < 2.0 * cfg.friction.smoothing_velocity).any()) continue;
    model::JointVector tau(truth.n);
    for (int i = 0; i < truth.n; ++i) tau[i] = torque(rng);
    model::Twist X_dd;
    ASSERT_EQ(plant.acceleration(s.X, s.X_dot, tau, X_dd), model::Status::kOk);
    ASSERT_EQ(regressor(truth, data, s.X, s.X_dot, X_dd, W), model::Status::kOk);
    const Eigen::Vector3d JmT_tau = data.Jm.transpose() * tau;
    EXPECT_LT(relative_error(W * phi, JmT_tau), 1e-9) << "state " << k;
    ++checked;
  }
  EXPECT_GT(checked, 150);
}

TEST(Regressor, RefusesNonFiniteAccelerationAndUnreachablePoses) {
  const model::Model m = dual_v();
  model::Data data(m);
  RegressorRows W;
  EXPECT_EQ(
      regressor(m, data, m.home, model::Twist::Zero(), model::Twist(std::nan(""), 0.0, 0.0), W),
      model::Status::kInvalidInput);
  EXPECT_EQ(
      regressor(m, data, model::Pose(0.0, 2.0, 0.0), model::Twist::Zero(), model::Twist::Zero(), W),
      model::Status::kUnreachable);
}

}  // namespace
}  // namespace dualv::identification
