// `dualv run`: the paper's experiment in closed loop (default: the in-process simulation).
#include <fmt/core.h>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <string>
#include <vector>

#include "apps/commands.hpp"
#include "apps/config_path.hpp"
#include "apps/experiment/closed_loop.hpp"
#include "apps/experiment/report.hpp"
#include "apps/experiment/robot_config.hpp"
#include "control/trajectory/preflight.hpp"
#include "control/trajectory/program.hpp"

namespace dualv::apps {

namespace {

struct RunArgs {
  std::string config;
  std::string program;
  std::string out;
  double rate_hz = 0.0;
  std::vector<std::string> variants;
  bool plots = true;
};

std::string default_out_dir() {
  const std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::localtime(&now));
  return std::string("out/run-") + stamp;
}

int run(const RunArgs& args) {
  RobotConfig cfg = load_robot_config(resolve_config(args.config));
  if (args.rate_hz > 0.0) cfg.loop.period_ns = static_cast<std::int64_t>(1e9 / args.rate_hz + 0.5);
  const std::string program_file =
      args.program.empty() ? default_config_dir() + "/paper.yaml" : args.program;
  trajectory::ProgramContext ctx;
  ctx.start = cfg.model.home;
  ctx.home = cfg.model.home;
  ctx.workspace = cfg.trajectory.limits.workspace;
  const trajectory::Program program = trajectory::load_program_file(program_file, ctx);

  std::vector<Variant> variants;
  for (const auto& v : paper_variants())
    if (args.variants.empty() ||
        std::find(args.variants.begin(), args.variants.end(), v.name) != args.variants.end())
      variants.push_back(v);
  for (const auto& name : args.variants) {
    const auto all = paper_variants();
    if (std::none_of(all.begin(), all.end(), [&](const Variant& v) { return v.name == name; })) {
      std::string known;
      for (const auto& v : all) known += " " + v.name;
      fmt::print(stderr, "dualv run: unknown variant '{}' (known:{})\n", name, known);
      return 2;
    }
  }

  // Pre-flight every variant before anything moves.
  for (const auto& v : variants)
    trajectory::preflight_or_throw(cfg.model, trajectory::with_timing(program, v.timing),
                                   cfg.trajectory.limits);

  const std::string out = args.out.empty() ? default_out_dir() : args.out;
  std::filesystem::create_directories(out);
  fmt::print("dualv run: {} ({} segments, {:.2f} s) on the in-process simulated Dual-V at {:.0f} Hz\n",
             program_file, program.size(), program.duration(), cfg.rate_hz());
  std::vector<RunResult> runs;
  for (const auto& v : variants) {
    RunOptions opts;
    // A terminal gets one line rewritten in place; a log gets a line per second of robot time.
    const bool tty = isatty(fileno(stdout));
    opts.progress = [tty](const std::string& name, double t, double duration) {
      if (tty) {
        fmt::print("\r  {:<24} t = {:5.2f} / {:.2f} s", name, t, duration);
        std::fflush(stdout);
      } else if (std::fmod(t + 1e-9, 1.0) < 0.5) {
        fmt::print("  {:<24} t = {:5.2f} / {:.2f} s\n", name, t, duration);
      }
    };
    runs.push_back(run_in_process(cfg, program, v, opts));
    const RunResult& r = runs.back();
    fmt::print("{}  {:<24} {} in {:.2f} s wall ({:.0f}x real time){}\n", tty ? "\r" : "", v.name, r.ok ? "done" : "FAILED", r.wall_time, r.robot_time / std::max(r.wall_time, 1e-9),
               r.ok ? "" : ": " + r.failure);
  }
  fmt::print("\n{}", summary_table(runs));
  write_csv(out, runs);
  if (args.plots) {
    const std::string why = draw_plots(out);
    if (!why.empty()) fmt::print(stderr, "dualv run: no plots: {}\n", why);
  }
  fmt::print("\nresults in {}/ (CSV time series, summary.csv{})\n", out, args.plots ? ", PNG figures" : "");
  for (const auto& r : runs)
    if (!r.ok) return 1;
  return 0;
}

}  // namespace

void register_run_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("run", "Run a program in closed loop (default: the paper's experiment "
                                        "on the in-process simulation)");
  static RunArgs args;
  add_config_option(*cmd, args.config);
  cmd->add_option("-p,--program", args.program, "Program YAML (default: paper.yaml beside the config)");
  cmd->add_option("-o,--out", args.out, "Output folder (default: out/run-<date>-<time>)");
  cmd->add_option("--rate", args.rate_hz, "Control rate [Hz] (default: loop.rate_hz)")
      ->check(CLI::Range(10.0, 20000.0));
  cmd->add_option("--variant", args.variants,
                  "Run only these variants: retimed, original, retimed-no-projection, "
                  "retimed-no-feedforward (default: all)");
  cmd->add_flag("!--no-plots", args.plots, "Skip the PNG figures");
  cmd->callback([] { exit_code() = run(args); });
}

}  // namespace dualv::apps
