#include "control/model/dynamics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <tuple>
#include <vector>

#include "control/model/kinematics.hpp"
#include "model_fixture.hpp"

namespace dualv::model {
namespace {

using test::dual_v;

// Independent truth: the world position (com x, com y, angle) of every body,
// written from the geometry alone (no Jacobians), for finite differences.
struct BodyPose {
  double x, y, angle, mass, inertia;
};

std::vector<BodyPose> body_poses(const Model& m, const Pose& X) {
  Data d(m);
  JointVector q;
  EXPECT_EQ(inverse_kinematics(m, d, X, q), Status::kOk);
  std::vector<BodyPose> out;
  auto place = [](Vec2 origin, double angle, Vec2 com) -> Vec2 {
    return origin + Vec2(std::cos(angle) * com.x() - std::sin(angle) * com.y(),
                         std::sin(angle) * com.x() + std::cos(angle) * com.y());
  };
  const Vec2 pc = place(X.head<2>(), X.z(), m.plate.com);
  out.push_back({pc.x(), pc.y(), X.z(), m.plate.mass, m.plate.inertia});
  for (int i = 0; i < m.n; ++i) {
    const Chain& ch = m.chains[i];
    const Vec2 B = ch.base + ch.crank_length * Vec2(std::cos(q[i]), std::sin(q[i]));
    const Vec2 C =
        X.head<2>() +
        Vec2(std::cos(X.z()) * ch.plate_anchor.x() - std::sin(X.z()) * ch.plate_anchor.y(),
             std::sin(X.z()) * ch.plate_anchor.x() + std::cos(X.z()) * ch.plate_anchor.y());
    const double phi = std::atan2(C.y() - B.y(), C.x() - B.x());
    const Vec2 c1 = place(ch.base, q[i], ch.crank.com);
    const Vec2 c2 = place(B, phi, ch.coupler.com);
    out.push_back({c1.x(), c1.y(), q[i], ch.crank.mass, ch.crank.inertia});
    out.push_back({c2.x(), c2.y(), phi, ch.coupler.mass, ch.coupler.inertia});
  }
  return out;
}

// A smooth trajectory around home: sums of sinusoids with random phases.
struct SmoothPath {
  Pose centre;
  Eigen::Vector3d amp, freq, phase;
  Pose X(double t) const {
    return centre + amp.cwiseProduct((freq * t + phase).array().sin().matrix());
  }
  Twist Xd(double t) const {
    return amp.cwiseProduct(freq).cwiseProduct((freq * t + phase).array().cos().matrix());
  }
  Twist Xdd(double t) const {
    return -amp.cwiseProduct(freq).cwiseProduct(freq).cwiseProduct(
        (freq * t + phase).array().sin().matrix());
  }
};

// d/dt of the total energy along the path, from five-point central differences of
// the body positions and angles (truncation O(h^4)); independent of the model's
// Jacobians and mass matrix.
double energy_rate_from_bodies(const Model& m, const SmoothPath& path, double t) {
  const double h = 1e-3;
  std::vector<std::vector<BodyPose>> s;
  for (int k = -2; k <= 2; ++k) s.push_back(body_poses(m, path.X(t + k * h)));
  double rate = 0.0;
  for (std::size_t b = 0; b < s[0].size(); ++b) {
    auto d1 = [&](auto f) {
      return (-f(s[4][b]) + 8 * f(s[3][b]) - 8 * f(s[1][b]) + f(s[0][b])) / (12 * h);
    };
    auto d2 = [&](auto f) {
      return (-f(s[4][b]) + 16 * f(s[3][b]) - 30 * f(s[2][b]) + 16 * f(s[1][b]) - f(s[0][b])) /
             (12 * h * h);
    };
    auto fx = [](const BodyPose& p) { return p.x; };
    auto fy = [](const BodyPose& p) { return p.y; };
    // Angles relative to the centre sample: atan2 wraps at +-pi.
    auto fa = [&](const BodyPose& p) { return std::remainder(p.angle - s[2][b].angle, 2 * M_PI); };
    const double vx = d1(fx), vy = d1(fy), w = d1(fa);
    const double ax = d2(fx), ay = d2(fy), al = d2(fa);
    const BodyPose& p = s[2][b];
    rate += p.mass * (vx * ax + vy * ay) + p.inertia * w * al;   // dT/dt
    rate -= p.mass * (m.gravity.x() * vx + m.gravity.y() * vy);  // dV/dt
  }
  return rate;
}

// (gravity in the plane, centres of mass off the links' axes)
class PowerBalance : public ::testing::TestWithParam<std::tuple<bool, bool>> {};

TEST_P(PowerBalance, JointPowerEqualsEnergyRateAlongASmoothTrajectory) {
  Model m = dual_v();
  const auto [gravity, off_axis] = GetParam();
  if (gravity) m.gravity = Vec2(0.0, -9.81);  // the tilted machine: gravity in the plane
  if (off_axis) {
    // The couplers' centres of mass on their axis take a faster, split form in
    // update_dynamics; off the axis, the general body form. Both must hold.
    for (int i = 0; i < m.n; ++i) {
      m.chains[i].crank.com = Vec2(0.12, 0.03);
      m.chains[i].coupler.com = Vec2(0.15, -0.02 * (i + 1));
    }
    m.plate.com = Vec2(0.01, -0.02);
  }
  Data d(m);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 5; ++trial) {
    SmoothPath path{m.home, Eigen::Vector3d(0.02, 0.02, 0.1),
                    Eigen::Vector3d(5 + 10 * u(rng), 5 + 10 * u(rng), 5 + 10 * u(rng)),
                    Eigen::Vector3d(6 * u(rng), 6 * u(rng), 6 * u(rng))};
    for (double t = 0.0; t < 1.0; t += 0.05) {
      JointVector tau;
      ASSERT_EQ(inverse_dynamics(m, d, path.X(t), path.Xd(t), path.Xdd(t), tau), Status::kOk);
      const double joint_power = tau.dot(d.q_dot);
      const double rate = energy_rate_from_bodies(m, path, t);
      EXPECT_NEAR(joint_power, rate, 1e-6 * std::max(1.0, std::abs(rate)))
          << "t = " << t << " trial " << trial;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(GravityAndOffAxis, PowerBalance,
                         ::testing::Combine(::testing::Bool(), ::testing::Bool()));

TEST(Dynamics, KineticEnergyEqualsTheQuadraticFormOfM) {
  const Model m = dual_v();
  Data d(m);
  const Twist Xd(0.1, -0.2, 0.5);
  ASSERT_EQ(update_dynamics(m, d, m.home + Pose(0.01, 0.02, 0.1), Xd), Status::kOk);
  const double quad = 0.5 * Xd.dot(d.M * Xd);
  EXPECT_NEAR(kinetic_energy(m, d, m.home + Pose(0.01, 0.02, 0.1), Xd), quad, 1e-12 * quad);
  EXPECT_LT((d.M - d.M.transpose()).norm(), 1e-14);
}

TEST(Dynamics, MasslessLinksLeaveOnlyThePlate) {
  Model m = dual_v();
  for (int i = 0; i < m.n; ++i) m.chains[i].crank = m.chains[i].coupler = Body{};
  m.plate.com = Vec2::Zero();
  Data d(m);
  ASSERT_EQ(update_dynamics(m, d, m.home + Pose(0.01, -0.01, 0.2), Twist(0.3, 0.1, 2.0)),
            Status::kOk);
  Mat3 expected = Eigen::Vector3d(m.plate.mass, m.plate.mass, m.plate.inertia).asDiagonal();
  EXPECT_LT((d.M - expected).norm(), 1e-14);
  EXPECT_LT(d.h.norm(), 1e-14);  // a free rigid body has no Coriolis term about its com
}

TEST(Dynamics, ForwardOfInverseReturnsTheAcceleration) {
  const Model m = dual_v();
  Data d(m);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 200; ++k) {
    const Pose X = m.home + Pose(0.05 * u(rng), 0.05 * u(rng), 0.2 * u(rng));
    const Twist Xd(0.3 * u(rng), 0.3 * u(rng), u(rng));
    const Twist Xdd(5 * u(rng), 5 * u(rng), 20 * u(rng));
    JointVector tau;
    ASSERT_EQ(inverse_dynamics(m, d, X, Xd, Xdd, tau), Status::kOk);
    // Any internal-force component added to tau must not change the motion.
    const JointVector tau_with_internal = tau + d.N * JointVector::Constant(m.n, 7.0);
    Twist out;
    ASSERT_EQ(forward_dynamics(m, d, X, Xd, tau_with_internal, out), Status::kOk);
    EXPECT_LT((out - Xdd).norm(), 1e-9 * (1.0 + Xdd.norm()));
  }
}

// One RK4 step of the free mechanism (zero torque, no friction).
void rk4_free(const Model& m, Data& d, Pose& X, Twist& Xd, double dt) {
  const JointVector zero = JointVector::Zero(m.n);
  auto acc = [&](const Pose& x, const Twist& v) {
    Twist a;
    EXPECT_EQ(forward_dynamics(m, d, x, v, zero, a), Status::kOk);
    return a;
  };
  const Twist k1v = acc(X, Xd);
  const Twist k2v = acc(X + 0.5 * dt * Xd, Xd + 0.5 * dt * k1v);
  const Twist k3v = acc(X + 0.5 * dt * (Xd + 0.5 * dt * k1v), Xd + 0.5 * dt * k2v);
  const Twist k4v = acc(X + dt * (Xd + 0.5 * dt * k2v), Xd + dt * k3v);
  const Twist k1x = Xd, k2x = Xd + 0.5 * dt * k1v, k3x = Xd + 0.5 * dt * k2v, k4x = Xd + dt * k3v;
  X += dt / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
  Xd += dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
}

class FreeMotion : public ::testing::TestWithParam<bool> {};

TEST_P(FreeMotion, ConservesEnergyOverOneSecondAtTenKilohertz) {
  Model m = dual_v();
  if (GetParam()) m.gravity = Vec2(0.0, -9.81);
  Data d(m);
  Pose X = m.home;
  Twist Xd(0.02, 0.015, 0.05);
  if (GetParam()) Xd.setZero();  // falls under gravity from rest
  const double E0 = kinetic_energy(m, d, X, Xd) + potential_energy(m, d, X);
  const double scale = GetParam() ? 0.1 : E0;  // gravity: judge drift against ~0.1 J exchanged
  double worst = 0.0;
  const double dt = 1e-4;
  const int steps = GetParam() ? 1000 : 10000;  // falling: 0.1 s keeps it inside the workspace
  for (int k = 0; k < steps; ++k) {
    rk4_free(m, d, X, Xd, dt);
    const double E = kinetic_energy(m, d, X, Xd) + potential_energy(m, d, X);
    worst = std::max(worst, std::abs(E - E0) / scale);
  }
  EXPECT_LT(worst, 1e-8);
  EXPECT_GT((X - m.home).norm(), 1e-3);  // it did move
  if (GetParam()) {
    EXPECT_GT(kinetic_energy(m, d, X, Xd), 1e-3);
  }
}

INSTANTIATE_TEST_SUITE_P(Gravity, FreeMotion, ::testing::Values(false, true));

TEST(Dynamics, InvalidInputsReturnAStatus) {
  const Model m = dual_v();
  Data d(m);
  JointVector tau;
  EXPECT_EQ(inverse_dynamics(m, d, m.home, Twist(NAN, 0, 0), Twist::Zero(), tau),
            Status::kInvalidInput);
  EXPECT_EQ(inverse_dynamics(m, d, Pose(0, 3, 0), Twist::Zero(), Twist::Zero(), tau),
            Status::kUnreachable);
  Twist a;
  EXPECT_EQ(forward_dynamics(m, d, m.home, Twist::Zero(), JointVector::Zero(2), a),
            Status::kInvalidInput);
}

}  // namespace
}  // namespace dualv::model
