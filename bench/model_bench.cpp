// The model's real-time work for one pose: IK + Jm + Jm_dot + inverse dynamics +
// projection (issue 2 target: < 2 us in all).
#include <benchmark/benchmark.h>

#include "control/config/model_config.hpp"
#include "control/model/dynamics.hpp"
#include "control/model/kinematics.hpp"
#include "control/model/lane_dynamics.hpp"

namespace {

using namespace dualv::model;

const Model& dual_v() {
  static const Model m = load_model_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  return m;
}

// The state every benchmark evaluates: a pose near home, a moderate twist.
const Pose kX = dual_v().home + Pose(0.01, -0.01, 0.05);
const Twist kXd(0.1, 0.05, 0.2);

void BM_InverseDynamicsWithProjection(benchmark::State& state) {
  const Model& m = dual_v();
  Data d(m);
  Pose X = kX;
  const Twist Xd = kXd, Xdd(2.0, -1.0, 5.0);
  JointVector tau(m.n), tau_star(m.n);
  for (auto _ : state) {
    // inverse_dynamics runs IK, Jm, Jm_dot, M, h, g and the projectors.
    inverse_dynamics(m, d, X, Xd, Xdd, tau);
    tau_star.noalias() = d.R * tau;
    benchmark::DoNotOptimize(tau_star.data());
    X.x() += 1e-12;  // defeat caching
  }
}
BENCHMARK(BM_InverseDynamicsWithProjection);

void BM_UpdateKinematics(benchmark::State& state) {
  const Model& m = dual_v();
  Data d(m);
  const Pose& X = kX;
  const Twist& Xd = kXd;
  for (auto _ : state) {
    update_kinematics(m, d, X, Xd);
    benchmark::DoNotOptimize(d.Jm_dot.data());
  }
}
BENCHMARK(BM_UpdateKinematics);

void BM_ForwardDynamics(benchmark::State& state) {
  const Model& m = dual_v();
  Data d(m);
  const Pose& X = kX;
  const Twist& Xd = kXd;
  JointVector tau = JointVector::Constant(m.n, 1.0);
  Twist Xdd;
  for (auto _ : state) {
    forward_dynamics(m, d, X, Xd, tau, Xdd);
    benchmark::DoNotOptimize(Xdd.data());
  }
}
BENCHMARK(BM_ForwardDynamics);

void BM_ForwardKinematicsWarmSeed(benchmark::State& state) {
  const Model& m = dual_v();
  Data d(m);
  const Pose& X = kX;
  JointVector q;
  inverse_kinematics(m, d, X, q);
  const Pose seed = X + Pose(1e-4, -1e-4, 1e-4);
  Pose out;
  for (auto _ : state) {
    forward_kinematics(m, d, q, seed, out);
    benchmark::DoNotOptimize(out.data());
  }
}
BENCHMARK(BM_ForwardKinematicsWarmSeed);

// The dynamics' parts: the velocity kinematics alone, then with the mass matrix and bias
// terms (scalar), then the same with the chains in SIMD lanes (the plant's right-hand side).
void BM_VelocityKinematics(benchmark::State& state) {
  const Model& m = dual_v();
  Data d(m);
  const Pose& X = kX;
  const Twist& Xd = kXd;
  for (auto _ : state) {
    update_velocity_kinematics(m, d, X, Xd);
    benchmark::DoNotOptimize(d.qdd_bias.data());
  }
}
BENCHMARK(BM_VelocityKinematics);

void BM_UpdateDynamics(benchmark::State& state) {
  const Model& m = dual_v();
  Data d(m);
  const Pose& X = kX;
  const Twist& Xd = kXd;
  for (auto _ : state) {
    update_dynamics(m, d, X, Xd);
    benchmark::DoNotOptimize(d.M.data());
  }
}
BENCHMARK(BM_UpdateDynamics);

// Argument 0: baseline x86-64 (SSE2); 1: AVX2 where this CPU has it.
void BM_LaneDynamics(benchmark::State& state) {
  const Model& m = dual_v();
  const LaneDynamics lanes(m, state.range(0) != 0);
  LaneDynamics::Output out;
  const Pose& X = kX;
  const Twist& Xd = kXd;
  for (auto _ : state) {
    lanes.update(X, Xd, out);
    benchmark::DoNotOptimize(out.M.data());
  }
  state.SetLabel(lanes.uses_avx2() ? "avx2" : "sse2");
}
BENCHMARK(BM_LaneDynamics)->Arg(1)->Arg(0);

}  // namespace
