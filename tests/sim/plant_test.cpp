// Plant physics and realism knobs, each isolated. Expected values come from physics
// (energy conservation, Jm^T N = 0, linearity of kinetic energy in the masses) or from
// the knob's definition written out here, never from the plant's own code.
#include "sim/plant.hpp"

#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cmath>
#include <numbers>

#include "control/model/dynamics.hpp"
#include "control/model/kinematics.hpp"
#include "tests/sim/sim_fixture.hpp"

namespace dualv::sim {
namespace {

using model::JointVector;
using model::Pose;
using model::Twist;
using test::dual_v;

constexpr double kCycle = 1e-3;  // [s] 1 kHz controller

JointVector joints(double a, double b, double c, double d) {
  JointVector v(4);
  v << a, b, c, d;
  return v;
}

// Runs `cycles` controller cycles holding `tau`.
PlantStatus run(Plant& p, const JointVector& tau, int cycles) {
  PlantStatus s = PlantStatus::kOk;
  for (int k = 0; k < cycles && s == PlantStatus::kOk; ++k) {
    p.command(tau);
    s = p.advance(kCycle);
  }
  return s;
}

TEST(Plant, StartsAtRestAtHome) {
  Plant p(dual_v(), PlantConfig{});
  EXPECT_EQ(p.status(), PlantStatus::kOk);
  EXPECT_TRUE(p.output().X.isApprox(dual_v().home));
  EXPECT_EQ(p.output().X_dot.norm(), 0.0);
  EXPECT_EQ(p.output().q.size(), 4);
}

TEST(Plant, AccelerationIsTheModelsForwardDynamicsWithoutFriction) {
  Plant p(dual_v(), PlantConfig::ideal());
  model::Data d(dual_v());
  const Pose X = dual_v().home + Pose(0.02, -0.01, 0.1);
  const Twist Xd(0.1, -0.2, 0.5);
  const JointVector tau = joints(3.0, -1.0, 2.0, 0.5);
  Twist a_plant, a_model;
  ASSERT_EQ(p.acceleration(X, Xd, tau, a_plant), model::Status::kOk);
  ASSERT_EQ(model::forward_dynamics(dual_v(), d, X, Xd, tau, a_model), model::Status::kOk);
  EXPECT_LT((a_plant - a_model).norm(), 1e-12 * a_model.norm());
  EXPECT_GT(a_model.norm(), 1.0);
}

TEST(Plant, AccelerationIsTheModelsForwardDynamicsForCouplersOffTheirAxes) {
  // Off-axis couplers take update_dynamics' general body form instead of the lanes.
  model::Model m = dual_v();
  for (int i = 0; i < m.n; ++i) m.chains[i].coupler.com = model::Vec2(0.14, 0.01 * (i + 1));
  Plant p(m, PlantConfig::ideal());
  model::Data d(m);
  const Pose X = m.home + Pose(0.02, -0.01, 0.1);
  const Twist Xd(0.1, -0.2, 0.5);
  const JointVector tau = joints(3.0, -1.0, 2.0, 0.5);
  Twist a_plant, a_model;
  ASSERT_EQ(p.acceleration(X, Xd, tau, a_plant), model::Status::kOk);
  ASSERT_EQ(model::forward_dynamics(m, d, X, Xd, tau, a_model), model::Status::kOk);
  EXPECT_LT((a_plant - a_model).norm(), 1e-12 * a_model.norm());
}

TEST(Plant, ZeroTorqueWithoutFrictionConservesEnergy) {
  Plant p(dual_v(), PlantConfig::ideal());
  ASSERT_EQ(p.reset(dual_v().home, Twist(0.05, -0.04, 0.3)), PlantStatus::kOk);
  const double e0 = p.energy();
  ASSERT_GT(e0, 1e-3);
  double worst = 0.0;
  for (int k = 0; k < 1000; ++k) {
    p.command(JointVector::Zero(4));
    ASSERT_EQ(p.advance(kCycle), PlantStatus::kOk) << "cycle " << k;
    worst = std::max(worst, std::abs(p.energy() - e0) / e0);
  }
  EXPECT_LT(worst, 1e-9);
  // It really moved: a conservation test of a plate at rest would prove nothing.
  EXPECT_GT((p.output().X.head<2>() - dual_v().home.head<2>()).norm(), 0.01);
  EXPECT_NEAR(p.output().time, 1.0, 1e-9);
}

TEST(Plant, EnergyDriftGrowsWithACoarserStep) {
  // The conservation test can fail: with 1 kHz RK4 steps the drift is far larger.
  PlantConfig coarse = PlantConfig::ideal();
  coarse.max_step = 1e-3;
  Plant fine(dual_v(), PlantConfig::ideal()), rough(dual_v(), coarse);
  const Twist v0(0.3, -0.3, 2.0);
  fine.reset(dual_v().home, v0);
  rough.reset(dual_v().home, v0);
  const double e0 = fine.energy();
  run(fine, JointVector::Zero(4), 300);
  run(rough, JointVector::Zero(4), 300);
  EXPECT_GT(std::abs(rough.energy() - e0), 100.0 * std::abs(fine.energy() - e0));
}

TEST(Plant, NullSpaceTorqueAtRestProducesNoAcceleration) {
  Plant p(dual_v(), PlantConfig::ideal());
  model::Data d(dual_v());
  ASSERT_EQ(model::update_kinematics(dual_v(), d, dual_v().home, Twist::Zero()),
            model::Status::kOk);
  ASSERT_EQ(model::update_projectors(dual_v(), d), model::Status::kOk);
  const JointVector internal = d.N * joints(10.0, -20.0, 15.0, 5.0);
  ASSERT_GT(internal.norm(), 1.0);  // a substantial antagonistic torque
  Twist a;
  ASSERT_EQ(p.acceleration(dual_v().home, Twist::Zero(), internal, a), model::Status::kOk);
  EXPECT_LT(a.norm(), 1e-11);
  // Control: a torque with a range component does accelerate the plate.
  ASSERT_EQ(p.acceleration(dual_v().home, Twist::Zero(), joints(1.0, 0.0, 0.0, 0.0), a),
            model::Status::kOk);
  EXPECT_GT(a.norm(), 1.0);
}

TEST(Plant, NullSpaceTorqueRecomputedEachCycleProducesNoMotion) {
  Plant p(dual_v(), PlantConfig::ideal());
  model::Data d(dual_v());
  const JointVector v = joints(10.0, -20.0, 15.0, 5.0);
  for (int k = 0; k < 1000; ++k) {
    const Pose X = p.output().X;
    ASSERT_EQ(model::update_kinematics(dual_v(), d, X, p.output().X_dot), model::Status::kOk);
    ASSERT_EQ(model::update_projectors(dual_v(), d), model::Status::kOk);
    const JointVector tau = d.N * v;
    p.command(tau);
    ASSERT_EQ(p.advance(kCycle), PlantStatus::kOk);
  }
  EXPECT_LT((p.output().X - dual_v().home).norm(), 1e-9);
  // The plant reports the whole torque as internal: N tau = tau, norm as applied.
  EXPECT_NEAR(p.output().internal_norm, p.output().tau_applied.norm(), 1e-9);
  EXPECT_GT(p.output().internal_norm, 1.0);
}

TEST(Plant, InternalTorqueIsTheNullSpaceComponentOfTheAppliedTorque) {
  Plant p(dual_v(), PlantConfig::ideal());
  p.command(joints(5.0, -3.0, 7.0, 1.0));
  ASSERT_EQ(p.advance(kCycle), PlantStatus::kOk);
  const PlantOutput& o = p.output();
  model::Data d(dual_v());
  ASSERT_EQ(model::update_kinematics(dual_v(), d, o.X, o.X_dot), model::Status::kOk);
  // Independent characterisation: internal torque produces no plate force (Jm^T t_i = 0)
  // and the remainder lies in range(Jm) (least-squares fit of Jm y reproduces it).
  EXPECT_LT((d.Jm.transpose() * o.tau_internal).norm(), 1e-10);
  const JointVector rest = o.tau_applied - o.tau_internal;
  const Eigen::Vector3d y = d.Jm.colPivHouseholderQr().solve(rest);
  EXPECT_LT((d.Jm * y - rest).norm(), 1e-10);
  EXPECT_GT(o.internal_norm, 0.1);
  EXPECT_DOUBLE_EQ(o.internal_norm, o.tau_internal.norm());
}

TEST(Plant, FrictionDissipatesEnergyWhenCoasting) {
  PlantConfig c = PlantConfig::ideal();
  c.friction.enabled = true;
  Plant p(dual_v(), c);
  ASSERT_EQ(p.reset(dual_v().home, Twist(0.05, -0.04, 0.3)), PlantStatus::kOk);
  const double e0 = p.energy();
  double previous = e0;
  int checked = 0;
  for (int k = 0; k < 2000 && previous > 1e-6 * e0; ++k, ++checked) {
    p.command(JointVector::Zero(4));
    ASSERT_EQ(p.advance(kCycle), PlantStatus::kOk);
    const double e = p.energy();
    ASSERT_LT(e, previous) << "cycle " << k;
    previous = e;
    // Friction opposes the joint velocity on every joint.
    for (int i = 0; i < 4; ++i)
      if (std::abs(p.output().q_dot[i]) > 1e-6) {
        EXPECT_GT(p.output().tau_friction[i] * p.output().q_dot[i], 0.0);
      }
  }
  EXPECT_GT(checked, 20);
  EXPECT_LT(p.energy(), 0.5 * e0);
}

TEST(Plant, FrictionFollowsItsLaw) {
  PlantConfig c = PlantConfig::ideal();
  c.friction.enabled = true;
  Plant p(dual_v(), c);
  // The smoothstep of PlantConfig::Friction written out: z (15 - 10 z^2 + 3 z^4) / 8 inside
  // |z| < 1, full Coulomb outside.
  auto law = [](double w) {
    const double z = w / 0.01;
    const double s = std::abs(z) < 1.0 ? (15 * z - 10 * z * z * z + 3 * std::pow(z, 5)) / 8
                                       : (z > 0 ? 1.0 : -1.0);
    return 0.2 * s + 0.02 * w;
  };
  int smoothed = 0, saturated = 0;
  for (const double speed : {0.05, 0.003, 0.0005}) {  // plate speeds [m/s]
    ASSERT_EQ(p.reset(dual_v().home, Twist(speed, -0.3 * speed, 0.0)), PlantStatus::kOk);
    const PlantOutput& o = p.output();
    for (int i = 0; i < 4; ++i) {
      const double w = o.q_dot[i];
      EXPECT_NEAR(o.tau_friction[i], law(w), 1e-12) << "q_dot " << w;
      (std::abs(w) < 0.01 ? smoothed : saturated) += 1;
    }
  }
  EXPECT_GE(smoothed, 4);  // both branches of the law were checked
  EXPECT_GE(saturated, 4);
}

TEST(Plant, EncoderQuantisesMeasuredPositionsInStepsOfTwoPiOverCounts) {
  PlantConfig c = PlantConfig::ideal();
  c.encoder.enabled = true;
  c.encoder.counts_per_revolution = 4096;
  Plant p(dual_v(), c);
  const double step = 2.0 * std::numbers::pi / 4096.0;
  ASSERT_EQ(p.reset(dual_v().home, Twist(0.02, 0.01, 0.1)), PlantStatus::kOk);
  int changes = 0;
  JointVector last = p.output().q_measured;
  for (int k = 0; k < 200; ++k) {
    ASSERT_EQ(run(p, JointVector::Zero(4), 1), PlantStatus::kOk);
    const PlantOutput& o = p.output();
    for (int i = 0; i < 4; ++i) {
      const double in_counts = o.q_measured[i] / step;
      EXPECT_NEAR(in_counts, std::round(in_counts), 1e-6);
      EXPECT_LE(std::abs(o.q_measured[i] - o.q[i]), 0.5 * step + 1e-12);
      EXPECT_EQ(static_cast<double>(o.counts[i]), std::round(in_counts));
      const double jump = (o.q_measured[i] - last[i]) / step;
      EXPECT_NEAR(jump, std::round(jump), 1e-6);
      if (o.q_measured[i] != last[i]) ++changes;
    }
    last = o.q_measured;
  }
  EXPECT_GT(changes, 10);
}

TEST(Plant, EncoderOffMeasuresTheTruePosition) {
  Plant p(dual_v(), PlantConfig::ideal());
  p.reset(dual_v().home + Pose(0.0123, 0.0, 0.0));
  for (int i = 0; i < 4; ++i) EXPECT_EQ(p.output().q_measured[i], p.output().q[i]);
}

TEST(Plant, TorqueIsQuantisedInPerMilleOfRatedTorque) {
  PlantConfig c = PlantConfig::ideal();
  c.torque_quantisation.enabled = true;
  c.torque_quantisation.rated_torque = 50.0;  // 1 per mille = 0.05 N m
  Plant p(dual_v(), c);
  p.command(joints(1.234, 1.224, -0.0249, -7.3381));
  p.advance(kCycle);
  const JointVector& a = p.output().tau_applied;
  EXPECT_NEAR(a[0], 1.25, 1e-12);               // 24.68 per mille -> 25
  EXPECT_NEAR(a[1], 1.20, 1e-12);               // 24.48 -> 24
  EXPECT_NEAR(a[2], 0.0, 1e-12);                // -0.498 -> 0
  EXPECT_NEAR(a[3], -7.35, 1e-12);              // -146.76 -> -147
  EXPECT_EQ(p.output().tau_command[0], 1.234);  // the command itself is reported unchanged
}

TEST(Plant, CurrentLoopIsAFirstOrderLag) {
  PlantConfig c = PlantConfig::ideal();
  c.current_loop.enabled = true;
  c.current_loop.time_constant = 2e-4;
  Plant p(dual_v(), c);
  p.command(joints(10.0, -10.0, 4.0, 0.0));
  ASSERT_EQ(p.advance(2e-4), PlantStatus::kOk);  // one time constant
  const double f = 1.0 - std::exp(-1.0);         // 63.2 %
  EXPECT_NEAR(p.output().tau_applied[0], 10.0 * f, 1e-9);
  EXPECT_NEAR(p.output().tau_applied[1], -10.0 * f, 1e-9);
  EXPECT_NEAR(p.output().tau_applied[2], 4.0 * f, 1e-9);
  ASSERT_EQ(p.advance(8e-4), PlantStatus::kOk);  // 5 time constants in all
  EXPECT_NEAR(p.output().tau_applied[0], 10.0 * (1.0 - std::exp(-5.0)), 1e-9);
  // The lag acts on the motion too: less velocity gained than with the torque at once.
  Plant ideal(dual_v(), PlantConfig::ideal());
  ideal.command(joints(10.0, -10.0, 4.0, 0.0));
  ideal.advance(1e-3);
  EXPECT_LT(p.output().X_dot.head<2>().norm(), ideal.output().X_dot.head<2>().norm());
}

TEST(Plant, TorqueSaturatesAtThePeak) {
  PlantConfig c = PlantConfig::ideal();
  c.saturation.enabled = true;
  Plant p(dual_v(), c);
  p.command(joints(200.0, -300.0, 126.5, -127.0));
  p.advance(kCycle);
  const JointVector& a = p.output().tau_applied;
  EXPECT_EQ(a[0], 127.0);
  EXPECT_EQ(a[1], -127.0);
  EXPECT_EQ(a[2], 126.5);
  EXPECT_EQ(a[3], -127.0);
}

TEST(Plant, TransportDelayAppliesACommandOneCycleLater) {
  PlantConfig c = PlantConfig::ideal();
  c.transport_delay.enabled = true;
  Plant p(dual_v(), c);
  p.command(joints(1.0, 1.0, 1.0, 1.0));  // cycle 0
  p.advance(kCycle);
  EXPECT_EQ(p.output().tau_applied[0], 0.0);
  EXPECT_EQ(p.output().X_dot.norm(), 0.0);  // nothing acted yet
  p.command(joints(2.0, 2.0, 2.0, 2.0));    // cycle 1
  p.advance(kCycle);
  EXPECT_EQ(p.output().tau_applied[0], 1.0);
  p.command(joints(3.0, 3.0, 3.0, 3.0));  // cycle 2
  p.advance(kCycle);
  EXPECT_EQ(p.output().tau_applied[0], 2.0);
  p.advance(kCycle);  // no new command: the drive holds the last one
  EXPECT_EQ(p.output().tau_applied[0], 3.0);
}

TEST(Plant, TransportDelayOfTwoCycles) {
  PlantConfig c = PlantConfig::ideal();
  c.transport_delay.enabled = true;
  c.transport_delay.cycles = 2;
  Plant p(dual_v(), c);
  const double expected[] = {0.0, 0.0, 1.0, 2.0, 3.0};
  for (int k = 0; k < 5; ++k) {
    p.command(JointVector::Constant(4, k + 1.0));
    p.advance(kCycle);
    EXPECT_EQ(p.output().tau_applied[0], expected[k]) << "cycle " << k;
  }
}

TEST(Plant, MismatchScalesTheTrueMassesAndInertias) {
  PlantConfig c = PlantConfig::ideal();
  c.mismatch.enabled = true;
  c.mismatch.crank = {5.0, 5.0};
  c.mismatch.coupler = {5.0, 5.0};
  c.mismatch.plate = {10.0, 20.0};
  Plant p(dual_v(), c);
  const model::Model& t = p.true_model();
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(t.chains[i].crank.mass, 1.169 * 1.05, 1e-12);  // Table I values
    EXPECT_NEAR(t.chains[i].crank.inertia, 0.012967 * 1.05, 1e-12);
    EXPECT_NEAR(t.chains[i].coupler.mass, 0.606 * 1.05, 1e-12);
    EXPECT_NEAR(t.chains[i].coupler.inertia, 0.006417 * 1.05, 1e-12);
  }
  EXPECT_NEAR(t.plate.mass, 0.899 * 1.10, 1e-12);
  EXPECT_NEAR(t.plate.inertia, 0.008168 * 1.20, 1e-12);
  EXPECT_EQ(t.chains[0].crank_length, 0.28);  // geometry untouched
}

TEST(Plant, MismatchChangesTheDynamics) {
  // Kinetic energy is linear in the masses: +5 % on every body -> exactly +5 % energy for
  // the same motion.
  PlantConfig c = PlantConfig::ideal();
  c.mismatch.enabled = true;
  c.mismatch.crank = c.mismatch.coupler = c.mismatch.plate = {5.0, 5.0};
  Plant heavy(dual_v(), c), nominal(dual_v(), PlantConfig::ideal());
  const Twist v(0.1, -0.05, 0.4);
  heavy.reset(dual_v().home, v);
  nominal.reset(dual_v().home, v);
  EXPECT_NEAR(heavy.kinetic_energy() / nominal.kinetic_energy(), 1.05, 1e-12);
  // ...and, gravity being off, M X_dd + h = Jm^T tau scales: the 5 % heavier plant under
  // tau moves exactly like the nominal one under tau / 1.05, and not like it under tau.
  heavy.reset(dual_v().home);
  nominal.reset(dual_v().home);
  Plant same_torque(dual_v(), PlantConfig::ideal());
  const JointVector tau = joints(2.0, -1.0, 0.5, 1.0);
  run(heavy, tau, 100);
  run(nominal, tau / 1.05, 100);
  run(same_torque, tau, 100);
  const double moved = (nominal.output().X - dual_v().home).norm();
  ASSERT_GT(moved, 1e-3);
  EXPECT_LT((heavy.output().X - nominal.output().X).norm(), 1e-9 * moved);
  EXPECT_GT((same_torque.output().X - heavy.output().X).norm(), 0.01 * moved);
}

TEST(Plant, ShippedConfigurationRunsWithEveryKnobOn) {
  const PlantConfig c = load_plant_config_file(test::config_file());
  Plant p(dual_v(), c);
  for (int k = 0; k < 1000; ++k) {
    const double t = k * kCycle;
    const double s = std::sin(2.0 * std::numbers::pi * 2.0 * t);
    p.command(joints(2.0 * s, -1.5 * s, 1.0 * s, 0.7 * s));
    ASSERT_EQ(p.advance(kCycle), PlantStatus::kOk) << "cycle " << k;
    const PlantOutput& o = p.output();
    ASSERT_TRUE(o.X.allFinite() && o.X_dot.allFinite() && o.tau_applied.allFinite());
  }
  EXPECT_GT(p.output().internal_norm, 0.0);
  EXPECT_GT((p.output().X - dual_v().home).norm(), 1e-4);
}

TEST(Plant, LeavingTheWorkspaceLatchesUnreachableWithoutNaN) {
  Plant p(dual_v(), PlantConfig::ideal());
  // Push every crank the same way: the plate is driven out of reach within a second.
  PlantStatus s = PlantStatus::kOk;
  int k = 0;
  for (; k < 5000 && s == PlantStatus::kOk; ++k) s = run(p, joints(20.0, 20.0, 20.0, 20.0), 1);
  ASSERT_EQ(s, PlantStatus::kUnreachable);
  EXPECT_NE(p.output().fault, model::Status::kOk);
  const Pose frozen = p.output().X;
  EXPECT_TRUE(frozen.allFinite());
  EXPECT_TRUE(p.output().X_dot.allFinite());
  EXPECT_TRUE(p.output().q_measured.allFinite());
  // Latched: further cycles change nothing and keep reporting it.
  EXPECT_EQ(run(p, JointVector::Zero(4), 3), PlantStatus::kUnreachable);
  EXPECT_EQ(p.output().X, frozen);
  EXPECT_EQ(p.status(), PlantStatus::kUnreachable);
  // reset() clears it.
  EXPECT_EQ(p.reset(dual_v().home), PlantStatus::kOk);
  EXPECT_EQ(p.status(), PlantStatus::kOk);
  EXPECT_EQ(run(p, JointVector::Zero(4), 3), PlantStatus::kOk);
}

TEST(Plant, ResetToAnUnreachablePoseIsRefused) {
  Plant p(dual_v(), PlantConfig::ideal());
  EXPECT_EQ(p.reset(Pose(0.0, 5.0, 0.0)), PlantStatus::kUnreachable);
  EXPECT_TRUE(p.output().X.isApprox(dual_v().home));
  EXPECT_EQ(p.status(), PlantStatus::kOk);
}

TEST(Plant, InvalidCommandAppliesNoTorque) {
  Plant p(dual_v(), PlantConfig::ideal());
  EXPECT_EQ(p.command(joints(1.0, NAN, 0.0, 0.0)), PlantStatus::kInvalidCommand);
  EXPECT_EQ(p.command(JointVector::Zero(3)), PlantStatus::kInvalidCommand);
  ASSERT_EQ(p.advance(kCycle), PlantStatus::kOk);
  EXPECT_EQ(p.output().tau_applied.norm(), 0.0);
  EXPECT_EQ(p.output().X_dot.norm(), 0.0);
}

TEST(Plant, InvalidPeriodIsRefused) {
  Plant p(dual_v(), PlantConfig::ideal());
  EXPECT_EQ(p.advance(0.0), PlantStatus::kInvalidPeriod);
  EXPECT_EQ(p.advance(-1e-3), PlantStatus::kInvalidPeriod);
  EXPECT_EQ(p.advance(NAN), PlantStatus::kInvalidPeriod);
  EXPECT_EQ(p.advance(1e6), PlantStatus::kInvalidPeriod);
  EXPECT_EQ(p.output().cycle, 0u);
}

TEST(Plant, StepCountFollowsTheIntegrationRate) {
  // 1 ms at 10 kHz is exactly 10 steps: the time advances by exactly the period.
  Plant p(dual_v(), PlantConfig::ideal());
  for (int k = 0; k < 1000; ++k) p.advance(kCycle);
  EXPECT_NEAR(p.output().time, 1.0, 1e-12);
  EXPECT_EQ(p.output().cycle, 1000u);
}

TEST(Plant, StatusNames) {
  EXPECT_STREQ(to_string(PlantStatus::kOk), "ok");
  EXPECT_STREQ(to_string(PlantStatus::kUnreachable), "unreachable");
}

}  // namespace
}  // namespace dualv::sim
