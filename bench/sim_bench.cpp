// Simulation speed of the plant: seconds of robot time per second of wall time at 1 kHz
// control / 10 kHz RK4 (issue 4 target: > 200x for the paper program). One benchmark
// iteration is one controller cycle: command + advance(1 ms) (10 RK4 steps, 40
// forward-dynamics evaluations) + output. The "robot_s_per_wall_s" counter is the speed-up
// over real time (Google Benchmark rates use CPU time: on a shared machine, the plant's own
// cost).
#include <benchmark/benchmark.h>

#include <cmath>

#include <vector>

#include "control/config/model_config.hpp"
#include "control/controller/controller.hpp"
#include "control/loop/control_cycle.hpp"
#include "control/model/lane_dynamics.hpp"
#include "control/trajectory/limits.hpp"
#include "control/trajectory/program.hpp"
#include "sim/plant.hpp"
#include "sim/sim_actuator_set.hpp"

namespace {

using namespace dualv;

constexpr double kCycle = 1e-3;  // [s] 1 kHz control

const model::Model& dual_v() {
  static const model::Model m =
      model::load_model_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  return m;
}

// A fixed sinusoidal torque pattern (2 Hz, a few N m: the plate oscillates by
// millimetres about home) and counts robot time.
void run_plant(benchmark::State& state, const sim::PlantConfig& config) {
  sim::Plant plant(dual_v(), config);
  model::JointVector tau(4);
  std::int64_t k = 0;
  for (auto _ : state) {
    const double s = std::sin(2.0 * M_PI * 2.0 * kCycle * static_cast<double>(k++));
    tau << 3.0 * s, -2.0 * s, 1.5 * s, -1.0 * s;
    plant.command(tau);
    if (plant.advance(kCycle) != sim::PlantStatus::kOk) plant.reset(dual_v().home);
    benchmark::DoNotOptimize(plant.output().X.data());
  }
  state.counters["robot_s_per_wall_s"] = benchmark::Counter(
      kCycle * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

// The paper program (config/paper.yaml) as the plant sees it: the torque commands of one
// closed-loop run at 1 kHz (recorded once, untimed) replayed into a fresh plant with the
// same configuration, which then moves exactly as in that run.
// Argument 0: the baseline x86-64 (SSE2) dynamics, as on a CPU without AVX2; 1: AVX2 where
// this CPU has it.
void BM_PlantPaperProgram(benchmark::State& state) {
  const std::string dir = std::string(DUALV_SOURCE_DIR) + "/config/";
  const YAML::Node root = YAML::LoadFile(dir + "dualv.yaml");
  sim::PlantConfig config = sim::load_plant_config(root["plant"]);
  config.allow_avx2 = state.range(0) != 0;
  std::vector<model::JointVector> commands;
  {
    const control::ControlSetup setup = control::load_control_config(root["controller"], 4);
    const auto traj = trajectory::load_trajectory_config(root["trajectory"]);
    trajectory::ProgramContext ctx;
    ctx.start = ctx.home = dual_v().home;
    const trajectory::Program program = trajectory::load_program_file(dir + "paper.yaml", ctx);
    sim::Plant plant(dual_v(), config);
    sim::SimActuatorSet io(plant);
    control::ControlCycle cycle(dual_v(), setup, {kCycle, 2.0});
    cycle.start(io, program, traj.rebase);
    control::CycleRecord rec;
    const int cycles = static_cast<int>(program.duration() / kCycle) + 100;
    for (int k = 0; k < cycles; ++k) {
      cycle.step(io, rec);
      commands.push_back(plant.output().tau_command);
      plant.advance(kCycle);
    }
  }
  sim::Plant plant(dual_v(), config);
  std::size_t k = 0;
  for (auto _ : state) {
    if (k == commands.size()) {
      k = 0;
      plant.reset(dual_v().home);
    }
    plant.command(commands[k++]);
    if (plant.advance(kCycle) != sim::PlantStatus::kOk) plant.reset(dual_v().home);
    benchmark::DoNotOptimize(plant.output().X.data());
  }
  state.counters["robot_s_per_wall_s"] = benchmark::Counter(
      kCycle * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.SetLabel(model::LaneDynamics(dual_v(), config.allow_avx2).uses_avx2() ? "AVX2" : "SSE2");
}
BENCHMARK(BM_PlantPaperProgram)->Arg(1)->Arg(0);

void BM_PlantCycleAllKnobs(benchmark::State& state) {
  run_plant(state,
            sim::load_plant_config_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml"));
}
BENCHMARK(BM_PlantCycleAllKnobs);

void BM_PlantCycleIdeal(benchmark::State& state) { run_plant(state, sim::PlantConfig::ideal()); }
BENCHMARK(BM_PlantCycleIdeal);

// The in-process closed-loop I/O around it: read + write through the actuator set.
void BM_SimActuatorSetCycle(benchmark::State& state) {
  sim::Plant plant(dual_v(), sim::PlantConfig{});
  sim::SimActuatorSet set(plant);
  drivers::ActuatorFeedback fb;
  drivers::ActuatorCommand cmd;
  cmd.n = 4;
  cmd.request = drivers::DriveRequest::kEnable;
  std::int64_t k = 0;
  for (auto _ : state) {
    set.read(fb);
    const double s = std::sin(2.0 * M_PI * 2.0 * kCycle * static_cast<double>(k++));
    for (int i = 0; i < 4; ++i) cmd.torque[i] = (i % 2 ? -2.0 : 2.0) * s;
    set.write(cmd);
    if (plant.advance(kCycle) != sim::PlantStatus::kOk) plant.reset(dual_v().home);
    benchmark::DoNotOptimize(fb.drive[0].position);
  }
  state.counters["robot_s_per_wall_s"] = benchmark::Counter(
      kCycle * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimActuatorSetCycle);

}  // namespace
