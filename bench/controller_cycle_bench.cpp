// Controller cycle time (issue 4): estimator + trajectory sample + control law + projection,
// i.e. ControlCycle::step() against the in-process drives, over the paper program at 1 kHz.
// Prints median, p99, p99.9 and max in ns (targets: median < 2 us, p99.9 < 10 us).
// A table, not a Google Benchmark: the tail of the distribution is what matters here.
#include <fmt/core.h>

#include <time.h>
#include <algorithm>
#include <vector>

#include "control/config/model_config.hpp"
#include "control/controller/controller.hpp"
#include "control/loop/control_cycle.hpp"
#include "control/loop/periodic_executive.hpp"
#include "control/trajectory/limits.hpp"
#include "control/trajectory/program.hpp"
#include "sim/plant.hpp"
#include "sim/sim_actuator_set.hpp"

// CPU time of this thread: the cycle's own cost, unaffected by other processes on a shared
// machine (wall-clock jitter of the real loop is `dualv run --realtime`'s report).
double thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e9 + static_cast<double>(ts.tv_nsec);
}

int main() {
  using namespace dualv;
  const std::string dir = std::string(DUALV_SOURCE_DIR) + "/config/";
  const YAML::Node root = YAML::LoadFile(dir + "dualv.yaml");
  const model::Model m = model::load_model(root["model"]);
  const control::ControlSetup setup = control::load_control_config(root["controller"], m.n);
  const auto traj = trajectory::load_trajectory_config(root["trajectory"]);
  trajectory::ProgramContext ctx;
  ctx.start = ctx.home = m.home;
  const trajectory::Program program = trajectory::load_program_file(dir + "paper.yaml", ctx);

  const double period = 1e-3;
  sim::Plant plant(m, sim::load_plant_config(root["plant"]));
  plant.reset(m.home);
  sim::SimActuatorSet io(plant);
  control::ControlCycle cycle(m, setup, {period, 2.0});
  cycle.start(io, program, traj.rebase);
  control::CycleRecord rec;

  const int cycles = static_cast<int>(program.duration() / period) + 500;
  std::vector<double> ns;
  ns.reserve(static_cast<std::size_t>(cycles) * 3);
  for (int pass = 0; pass < 3; ++pass) {
    plant.reset(m.home);
    cycle.start(io, program, traj.rebase);
    for (int k = 0; k < cycles; ++k) {
      const double t0 = thread_cpu_ns();
      cycle.step(io, rec);
      ns.push_back(thread_cpu_ns() - t0);
      plant.advance(period);
    }
  }
  std::sort(ns.begin(), ns.end());
  auto pct = [&](double p) {
    return ns[static_cast<std::size_t>(p * static_cast<double>(ns.size() - 1))];
  };
  fmt::print(
      "controller cycle (read + estimate + sample + control + projection + safety + write), "
      "thread CPU time, {} cycles\n",
      ns.size());
  fmt::print("{:>10} {:>10} {:>10} {:>10} {:>10}\n", "min ns", "median ns", "p99 ns", "p99.9 ns",
             "max ns");
  fmt::print("{:>10.0f} {:>10.0f} {:>10.0f} {:>10.0f} {:>10.0f}\n", ns.front(), pct(0.5), pct(0.99),
             pct(0.999), ns.back());
  fmt::print("targets: median < 2000 ns {}, p99.9 < 10000 ns {}\n",
             pct(0.5) < 2000 ? "met" : "MISSED", pct(0.999) < 10000 ? "met" : "MISSED");
  return 0;
}
