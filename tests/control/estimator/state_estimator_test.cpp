#include "control/estimator/state_estimator.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "control/config/model_config.hpp"
#include "control/model/kinematics.hpp"

namespace dualv::control {
namespace {

model::Model dual_v() {
  return model::load_model_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
}

TEST(StateEstimator, VelocityStepFollowsTheFirstOrderLowPass) {
  const auto m = dual_v();
  const double dt = 1e-3, fc = 100.0;
  StateEstimator est(m, {fc}, dt);
  model::Data d(m);
  const model::Twist v(0.02, 0.0, 0.0);  // constant plate velocity from rest
  model::Pose X = m.home;
  ASSERT_EQ(model::update_kinematics(m, d, X, model::Twist::Zero()), model::Status::kOk);
  est.reset(d.q, X);
  const double alpha = dt / (dt + 1.0 / (2 * M_PI * fc));
  for (int k = 1; k <= 50; ++k) {
    X += v * dt;
    ASSERT_EQ(model::update_kinematics(m, d, X, v), model::Status::kOk);
    ASSERT_EQ(est.update(d.q), EstimateStatus::kOk);
    // After k samples of a ramp a first-order filter has reached 1 - (1 - alpha)^k of the slope.
    const double reached = 1.0 - std::pow(1.0 - alpha, k);
    EXPECT_NEAR(est.estimate().X_dot.x(), reached * v.x(), 0.02 * v.x()) << "k " << k;
    EXPECT_LT((est.estimate().X - X).norm(), 1e-10);
  }
}

// A joint whose position does not arrive for two cycles (its TPDO lost; the actuator set
// repeats the old position with fresh = false): the estimate follows the true motion (the
// kinematics of a plate moving at constant velocity) instead of reading the held position as a
// stop and the next fresh one as a jump.
TEST(StateEstimator, AJointWithoutAFreshPositionIsExtrapolatedNotHeld) {
  const auto m = dual_v();
  const double dt = 1e-3;
  StateEstimator est(m, {250.0}, dt);
  model::Data d(m);
  const model::Twist v(0.2, -0.1, 0.0);  // m/s: joint velocities of ~1 rad/s
  model::Pose X = m.home;
  ASSERT_EQ(model::update_kinematics(m, d, X, v), model::Status::kOk);
  est.reset(d.q, X);
  model::JointVector held = d.q;
  const std::uint32_t all = 0xF, without_joint_2 = 0xF & ~(1U << 1);
  for (int k = 1; k <= 120; ++k) {
    X += v * dt;
    ASSERT_EQ(model::update_kinematics(m, d, X, v), model::Status::kOk);
    const bool stale = k == 101 || k == 102;  // after the filter has settled
    model::JointVector q = d.q;
    if (stale)
      q[1] = held[1];
    else
      held = d.q;
    ASSERT_EQ(est.update(q, stale ? without_joint_2 : all), EstimateStatus::kOk) << "k " << k;
    if (k < 100) continue;
    // Extrapolated over 2 ms at the estimated velocity, which lags the true one by about
    // q_ddot (1 / (2 pi f_c) + dt / 2) (the low-pass and the backward difference): a few
    // 1e-6 rad here. Holding it would be off by q_dot dt, ~1e-3 rad, per cycle.
    EXPECT_NEAR(est.estimate().q[1], d.q[1], 1e-5) << "k " << k;
    // The velocity stays on the true one (the filter's lag on a slowly changing velocity
    // aside); held, it would dip by alpha (about 60 %) and then overshoot.
    EXPECT_NEAR(est.estimate().q_dot[1], d.q_dot[1], 0.01 * std::abs(d.q_dot[1])) << "k " << k;
    EXPECT_LT((est.estimate().X - X).norm(), 1e-5) << "k " << k;
  }
}

TEST(StateEstimator, BadPositionsLeaveTheEstimateAndSayWhy) {
  const auto m = dual_v();
  StateEstimator est(m, {200.0}, 1e-3);
  model::Data d(m);
  ASSERT_EQ(model::update_kinematics(m, d, m.home, model::Twist::Zero()), model::Status::kOk);
  est.reset(d.q, m.home);
  model::JointVector q = d.q;
  q[1] = NAN;
  EXPECT_EQ(est.update(q), EstimateStatus::kInvalidInput);
  EXPECT_TRUE(est.estimate().q.allFinite());
  q = d.q;
  q[0] += 0.5;  // one encoder jumps half a radian: no rigid plate explains it
  EXPECT_EQ(est.update(q), EstimateStatus::kFkFailed);
  EXPECT_LT((est.estimate().X - m.home).norm(), 1e-12);  // last good pose kept
}

}  // namespace
}  // namespace dualv::control
