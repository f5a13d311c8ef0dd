#include "apps/identify/recording_io.hpp"

#include <fmt/format.h>

#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "dualv_lcm/robot_state_t.hpp"
#include "runtime/channels.hpp"

namespace dualv::apps {

identification::Recording recording_from_run(const RunResult& run, double period) {
  identification::Recording rec;
  rec.period = period;
  for (const Row& row : run.rows) {
    rec.t.push_back(row.t);
    rec.X.push_back(row.X);
    rec.X_ref.push_back(row.X_d);
    model::JointVector tau(run.n);
    for (int i = 0; i < run.n; ++i) tau[i] = row.tau[i];
    rec.tau.push_back(tau);
  }
  return rec;
}

namespace {

double median_step(const std::vector<double>& t) {
  std::vector<double> d;
  for (std::size_t k = 1; k < t.size(); ++k) d.push_back(t[k] - t[k - 1]);
  if (d.empty()) return 0.0;
  std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

identification::Recording read_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(fmt::format("cannot read {}", path));
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(fmt::format("{}: empty file", path));
  std::vector<std::string> head;
  {
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) head.push_back(c);
  }
  auto col = [&](const std::string& name) -> int {
    for (std::size_t k = 0; k < head.size(); ++k)
      if (head[k] == name) return static_cast<int>(k);
    return -1;
  };
  const int it = col("t"), ix = col("x"), iy = col("y"), ith = col("theta");
  const int ixd = col("x_d"), iyd = col("y_d"), ithd = col("theta_d");
  const bool has_ref = ixd >= 0 && iyd >= 0 && ithd >= 0;
  std::vector<int> itau;
  for (int i = 1; col(fmt::format("tau{}", i)) >= 0; ++i)
    itau.push_back(col(fmt::format("tau{}", i)));
  if (it < 0 || ix < 0 || iy < 0 || ith < 0 || itau.size() < 3)
    throw std::runtime_error(
        fmt::format("{}: needs the columns t, x, y, theta and tau1..tauN of `dualv run` (got: {})",
                    path, line));
  identification::Recording rec;
  std::size_t lineno = 1;
  while (std::getline(in, line)) {
    ++lineno;
    std::vector<double> v;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) v.push_back(std::strtod(c.c_str(), nullptr));
    if (v.size() < head.size())
      throw std::runtime_error(
          fmt::format("{}:{}: {} values for {} columns", path, lineno, v.size(), head.size()));
    rec.t.push_back(v[static_cast<std::size_t>(it)]);
    rec.X.emplace_back(v[static_cast<std::size_t>(ix)], v[static_cast<std::size_t>(iy)],
                       v[static_cast<std::size_t>(ith)]);
    if (has_ref)
      rec.X_ref.emplace_back(v[static_cast<std::size_t>(ixd)], v[static_cast<std::size_t>(iyd)],
                             v[static_cast<std::size_t>(ithd)]);
    model::JointVector tau(static_cast<int>(itau.size()));
    for (std::size_t i = 0; i < itau.size(); ++i)
      tau[static_cast<int>(i)] = v[static_cast<std::size_t>(itau[i])];
    rec.tau.push_back(tau);
  }
  rec.period = median_step(rec.t);
  return rec;
}

identification::Recording read_lcm(const std::string& path) {
  lcm::LogFile log(path, "r");
  if (!log.good()) throw std::runtime_error(fmt::format("cannot read LCM log {}", path));
  identification::Recording best, run;
  std::int64_t last_cycle = -1;
  auto flush = [&] {
    if (run.size() > best.size()) best = run;
    run = {};
  };
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel != runtime::kStateChannel) continue;
    dualv_lcm::robot_state_t s;
    if (s.decode(ev->data, 0, ev->datalen) < 0) continue;
    if (s.cycle <= last_cycle) flush();  // the cycle counter restarts with every run
    last_cycle = s.cycle;
    run.t.push_back(s.t);
    run.X.emplace_back(s.X[0], s.X[1], s.X[2]);
    run.X_ref.emplace_back(s.X_d[0], s.X_d[1], s.X_d[2]);
    model::JointVector tau(s.n);
    for (int i = 0; i < s.n; ++i) tau[i] = s.tau_cmd[static_cast<std::size_t>(i)];
    run.tau.push_back(tau);
  }
  flush();
  if (best.size() == 0)
    throw std::runtime_error(
        fmt::format("{}: no robot states (channel {}) in the log", path, runtime::kStateChannel));
  best.period = median_step(best.t);
  return best;
}

}  // namespace

identification::Recording read_recording(const std::string& path) {
  const bool is_lcm = path.size() >= 7 && path.substr(path.size() - 7) == ".lcmlog";
  identification::Recording rec = is_lcm ? read_lcm(path) : read_csv(path);
  if (!(rec.period > 0.0))
    throw std::runtime_error(
        fmt::format("{}: times do not increase (sample period {})", path, rec.period));
  return rec;
}

double drive_latency(const RobotConfig& config) {
  const auto& p = config.plant;
  double cycles = 0.5;
  if (p.transport_delay.enabled) cycles += p.transport_delay.cycles;
  return cycles * config.period() + (p.current_loop.enabled ? p.current_loop.time_constant : 0.0);
}

}  // namespace dualv::apps
