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
