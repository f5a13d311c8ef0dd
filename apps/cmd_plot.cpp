// `dualv plot PATH`: the paper-style figures from a `dualv run` output folder (its CSV time
// series) or from an LCM log of robot_state_t (e.g. <out>/telemetry.lcmlog, or one recorded
// with lcm-logger), which is first converted to one CSV per run.
#include <fmt/core.h>

#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <string>

#include "apps/commands.hpp"
#include "apps/experiment/report.hpp"
#include "dualv_lcm/robot_state_t.hpp"
#include "runtime/channels.hpp"

namespace dualv::apps {

namespace {

// Splits the log's robot states into runs (the cycle counter restarts with every run) and
// writes <dir>/<stem>-<k>.csv for each. Returns the number of runs.
int log_to_csv(const std::string& log_path, const std::string& dir) {
  lcm::LogFile log(log_path, "r");
  if (!log.good()) throw std::runtime_error(fmt::format("cannot read LCM log {}", log_path));
  const std::string stem = std::filesystem::path(log_path).stem().string();
  RunResult run;
  int runs = 0;
  std::int64_t last_cycle = -1;
  auto flush = [&] {
    if (run.rows.empty()) return;
    ++runs;
    write_run_csv(fmt::format("{}/{}-{}.csv", dir, stem, runs), run);
    run.rows.clear();
  };
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel != runtime::kStateChannel) continue;
    dualv_lcm::robot_state_t s;
    if (s.decode(ev->data, 0, ev->datalen) < 0) continue;  // not a robot state: skip it
    if (s.cycle <= last_cycle) flush();
    last_cycle = s.cycle;
    run.n = s.n;
    Row row;
    row.t = s.t;
    row.segment = s.segment;
    row.X_d = model::Pose(s.X_d[0], s.X_d[1], s.X_d[2]);
    row.X = model::Pose(s.X[0], s.X[1], s.X[2]);
    double internal = 0.0;
    for (int i = 0; i < s.n && i < drivers::kMaxDrives; ++i) {
      row.tau[i] = s.tau_cmd[i];
      internal += s.tau_internal[i] * s.tau_internal[i];
    }
    row.tau_internal = std::sqrt(internal);
    row.plant_internal = std::nan("");
    row.lambda = s.lambda;
    run.rows.push_back(row);
  }
  flush();
  return runs;
}

void plot(const std::string& path, std::string out) {
  namespace fs = std::filesystem;
  if (!fs::exists(path)) throw std::runtime_error(fmt::format("{}: no such file or folder", path));
  if (fs::is_directory(path)) {
    out = path;
  } else {
    if (out.empty()) out = fs::path(path).parent_path().string() + "/plots";
    fs::create_directories(out);
    const int runs = log_to_csv(path, out);
    if (runs == 0)
      throw std::runtime_error(
          fmt::format("{}: no {} messages in this LCM log", path, runtime::kStateChannel));
    fmt::print("dualv plot: {} run(s) from {} written as CSV to {}/\n", runs, path, out);
  }
  const std::string why = draw_plots(out);
  if (!why.empty()) throw std::runtime_error("no plots: " + why);
  fmt::print("dualv plot: figures in {}/\n", out);
}

}  // namespace

void register_plot_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "plot", "Draw the paper-style figures from a `dualv run` folder or an LCM log");
  static std::string path, out;
  cmd->add_option("path", path, "Run output folder (CSV) or LCM log (.lcmlog)")->required();
  cmd->add_option("-o,--out", out,
                  "Folder for CSV and figures from a log (default: <log dir>/plots)");
  cmd->callback([] { plot(path, out); });
}

}  // namespace dualv::apps
