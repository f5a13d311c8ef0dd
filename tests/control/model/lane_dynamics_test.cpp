// LaneDynamics against update_dynamics, whose mass matrix and biases the power-balance and
// energy tests check from first principles (dynamics_test.cpp): the same M, h + g, Jm and
// q_dot for any number of chains (padding lanes included), with and without gravity, on
// both code paths (SSE2 and AVX2), and the same status where update_dynamics fails.
#include "control/model/lane_dynamics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <ostream>
#include <random>
#include <stdexcept>

#include "control/model/dynamics.hpp"
#include "tests/control/model/model_fixture.hpp"

namespace dualv::model {
namespace {

using test::dual_v;

// An n-RRR ring around the Dual-V's home: bases on a 0.4 m circle, anchors on a 0.05 m
// one, every chain with its own masses (a lane mix-up shows) and alternating elbows.
Model ring(int n) {
  Model m = dual_v();
  m.n = n;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n + 0.3;
    Chain& ch = m.chains[i];
    ch = dual_v().chains[0];
    ch.base = m.home.head<2>() + 0.4 * Vec2(std::cos(a), std::sin(a));
    ch.plate_anchor = 0.05 * Vec2(std::cos(a), std::sin(a));
    ch.working_mode = i % 2 ? -1 : 1;
    const double k = 1.0 + 0.1 * i;
    ch.crank.mass *= k;
    ch.crank.inertia *= k * k;
    ch.crank.com = Vec2(0.1 + 0.01 * i, 0.01 * i);  // cranks may be off their axes
    ch.coupler.mass /= k;
    ch.coupler.com = Vec2(0.12 + 0.01 * i, 0.0);
  }
  m.plate.com = Vec2(0.004, -0.003);
  return m;
}

struct Case {
  int n;
  bool gravity;
  bool avx2;
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << c.n << " chains" << (c.gravity ? ", gravity" : "") << (c.avx2 ? ", AVX2" : ", SSE2");
}

class AgreesWithUpdateDynamics : public ::testing::TestWithParam<Case> {};

TEST_P(AgreesWithUpdateDynamics, OnRandomStates) {
  const Case c = GetParam();
  Model m = c.n == 4 ? dual_v() : ring(c.n);
  if (c.gravity) m.gravity = Vec2(0.0, -9.81);
  const LaneDynamics lanes(m, c.avx2);
  if (c.avx2 && !lanes.uses_avx2()) GTEST_SKIP() << "this CPU has no AVX2 + FMA";
  EXPECT_EQ(lanes.uses_avx2(), c.avx2);
  Data d(m);
  std::mt19937_64 rng(42 + c.n);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int compared = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const Pose X = m.home + Pose(0.05 * u(rng), 0.05 * u(rng), 0.3 * u(rng));
    const Twist Xd(0.5 * u(rng), 0.5 * u(rng), 3.0 * u(rng));
    LaneDynamics::Output out;
    const Status expected = update_dynamics(m, d, X, Xd);
    ASSERT_EQ(lanes.update(X, Xd, out), expected) << "trial " << trial;
    if (expected != Status::kOk) continue;
    ++compared;
    const double scale = d.M.norm();
    EXPECT_LT((out.M - d.M).norm(), 1e-12 * scale) << "trial " << trial;
    const Twist bias = d.h + d.g;
    EXPECT_LT((out.bias - bias).norm(), 1e-11 * (1.0 + bias.norm())) << "trial " << trial;
    for (int i = 0; i < m.n; ++i) {
      const Eigen::RowVector3d row(out.jm0[i], out.jm1[i], out.jm2[i]);
      EXPECT_LT((row - d.Jm.row(i)).norm(), 1e-12 * d.Jm.row(i).norm()) << "chain " << i;
      EXPECT_NEAR(out.q_dot[i], d.q_dot[i], 1e-12 * (1.0 + std::abs(d.q_dot[i])));
    }
  }
  EXPECT_GT(compared, 400);  // the comparison ran where both succeed
}

INSTANTIATE_TEST_SUITE_P(ChainsGravityPath, AgreesWithUpdateDynamics,
                         ::testing::Values(Case{4, false, false}, Case{4, false, true},
                                           Case{4, true, false}, Case{4, true, true},
                                           Case{3, true, false}, Case{3, true, true},
                                           Case{5, false, false}, Case{5, true, true},
                                           Case{8, true, false}, Case{8, true, true}),
                         [](const auto& test) {
                           return std::to_string(test.param.n) + "Chains" +
                                  (test.param.gravity ? "Gravity" : "") +
                                  (test.param.avx2 ? "Avx2" : "Sse2");
                         });

TEST(LaneDynamics, StatusesMatchUpdateDynamicsOutsideTheWorkspace) {
  const Model m = dual_v();
  Data d(m);
  for (const bool avx2 : {false, true}) {
    const LaneDynamics lanes(m, avx2);
    LaneDynamics::Output out;
    EXPECT_EQ(lanes.update(Pose(0.0, 2.0, 0.0), Twist::Zero(), out), Status::kUnreachable);
    EXPECT_EQ(lanes.update(Pose(NAN, 0.25, 0.0), Twist::Zero(), out), Status::kInvalidInput);
    EXPECT_EQ(lanes.update(m.home, Twist(0.0, INFINITY, 0.0), out), Status::kInvalidInput);
    // A sweep across the workspace boundary: each pose gives the status update_dynamics
    // gives (reachable, unreachable, or serially singular on the way).
    int failures = 0;
    for (int k = 0; k <= 400; ++k) {
      const Pose X = m.home + Pose(0.0, -0.4 + 0.002 * k, 0.0);
      const Status expected = update_dynamics(m, d, X, Twist::Zero());
      EXPECT_EQ(lanes.update(X, Twist::Zero(), out), expected) << "k = " << k;
      failures += expected != Status::kOk;
    }
    EXPECT_GT(failures, 10);
    EXPECT_LT(failures, 390);
  }
}

TEST(LaneDynamics, RefusesCouplersWithTheCentreOfMassOffTheAxis) {
  Model m = dual_v();
  EXPECT_TRUE(LaneDynamics::supports(m));
  m.chains[2].coupler.com = Vec2(0.14, 0.01);
  EXPECT_FALSE(LaneDynamics::supports(m));
  try {
    LaneDynamics lanes(m);
    FAIL() << "constructed";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("off its axis"), std::string::npos) << e.what();
  }
  m = dual_v();
  m.n = 2;
  EXPECT_FALSE(LaneDynamics::supports(m));
  EXPECT_THROW(LaneDynamics{m}, std::invalid_argument);
}

}  // namespace
}  // namespace dualv::model
