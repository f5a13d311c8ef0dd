#include "apps/experiment/robot_config.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>

#include "common/config_error.hpp"
#include "common/yaml_reader.hpp"
#include "control/config/model_config.hpp"

namespace dualv::apps {

namespace {

const char* section_purpose(const std::string& name) {
  if (name == "model") return "the mechanism: geometry, masses, chains";
  if (name == "trajectory") return "pre-flight limits, rebase and streaming limits";
  if (name == "plant") return "the simulated Dual-V's realism knobs";
  if (name == "controller") return "gains kp, kd, feedforward, projection, velocity filter";
  if (name == "loop") return "rate_hz: the control rate";
  if (name == "can") return "the CANopen bus and drives";
  if (name == "safety") return "torque, velocity and workspace limits, SS1, watchdogs";
  return "";
}

// The cross-checks that depend on the loop rate, for the file's rate at load and for
// `--rate` (override_rate); `rate_name` says which rate ("loop.rate_hz" or "--rate").
std::vector<std::string> rate_problems(const RobotConfig& cfg, const std::string& rate_name) {
  std::vector<std::string> problems;
  const std::string& path = cfg.path;
  // A filter above Nyquist aliases, a plant coarser than the loop cannot apply a command per
  // cycle, and the bus must carry one SYNC per control cycle.
  const double rate = cfg.rate_hz();
  const double period = cfg.period();
  const double cutoff = cfg.control.estimator.velocity_cutoff_hz;
  if (!(cutoff < 0.5 * rate))
    problems.push_back(
        fmt::format("{}: controller.velocity_cutoff_hz: must be below the loop's Nyquist rate "
                    "{} / 2 = {} Hz (got {})",
                    path, rate_name, 0.5 * rate, cutoff));
  const double plant_rate = 1.0 / cfg.plant.max_step;
  if (plant_rate < rate * (1.0 - 1e-9))
    problems.push_back(fmt::format("{}: plant.integration_rate: must be >= {} = {} Hz (got {})",
                                   path, rate_name, rate, plant_rate));
  const auto sync_ns = static_cast<double>(cfg.can.sync_period_ns);
  if (std::abs(sync_ns - static_cast<double>(cfg.loop.period_ns)) > 0.5)
    problems.push_back(fmt::format("{}: can.sync.period: must equal 1 / {} = {} s (got {} s)", path,
                                   rate_name, period, sync_ns * 1e-9));
  // The safety layer counts these in whole cycles (safety/safety_filter.cpp cycle_limits):
  // shorter than a cycle, a time would silently become one cycle, longer than configured.
  const std::pair<const char*, double> times[] = {
      {"safety.ss1.max_time", cfg.safety.ss1.max_time},
      {"safety.ss1.standstill_time", cfg.safety.ss1.standstill_time},
      {"safety.watchdogs.command_stream_timeout", cfg.safety.watchdogs.command_stream_timeout},
  };
  for (const auto& [key, t] : times)
    if (t < period * (1.0 - 1e-9))
      problems.push_back(fmt::format(
          "{}: {}: must last at least one control cycle, 1 / {} = {} s (got {} s): the safety "
          "layer counts it in whole cycles",
          path, key, rate_name, period, t));
  return problems;
}

}  // namespace

void override_rate(RobotConfig& cfg, double rate_hz, bool on_bus) {
  if (!(std::isfinite(rate_hz) && rate_hz > 0.0))
    throw ConfigError({fmt::format("--rate: must be a positive number of Hz (got {})", rate_hz)});
  RobotConfig c = cfg;
  c.loop.period_ns = static_cast<std::int64_t>(1e9 / rate_hz + 0.5);
  c.can.sync_period_ns = static_cast<std::uint64_t>(c.loop.period_ns);
  c.trajectory.limits.loop_period = c.period();
  const std::string rate_name = fmt::format("--rate {}", rate_hz);
  std::vector<std::string> problems = rate_problems(c, rate_name);
  // The `can:` rules that involve the SYNC period, and the bus's capacity when it is used.
  auto can_rules = [&](const std::function<void()>& check) {
    try {
      check();
    } catch (const ConfigError& e) {
      for (const auto& p : e.problems())
        problems.push_back(fmt::format("{}: {} (with {} Hz)", c.path, p, rate_name));
    }
  };
  can_rules([&] { drivers::validate(c.can); });
  if (on_bus) can_rules([&] { (void)drivers::require_bus_load_fits(c.can); });
  if (!problems.empty()) throw ConfigError(problems);
  cfg = std::move(c);
}

std::vector<std::string> check_robot_config(const std::string& path) {
  try {
    load_robot_config(path);
  } catch (const ConfigError& e) {
    return e.problems();
  }
  return {};
}

RobotConfig load_robot_config(const std::string& path) {
  // Duplicate keys and empty values are reported with the file's other problems, at once.
  std::vector<std::string> document;
  const YAML::Node root = YamlReader::load_file(path, &document);
  RobotConfig cfg;
  cfg.path = path;
  std::vector<std::string> problems = document;
  for (const char* name : kRequiredSections)
    if (!root[name].IsDefined())
      problems.push_back(fmt::format("{}: {}: missing section ({}); config/dualv.yaml shows it",
                                     path, name, section_purpose(name)));
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (std::find(kRequiredSections.begin(), kRequiredSections.end(), key) ==
        kRequiredSections.end())
      problems.push_back(
          fmt::format("{}: {}: unknown section (known: model, trajectory, plant, "
                      "controller, loop, can, safety)",
                      path, key));
  }
  if (problems.size() > document.size()) throw ConfigError(problems);  // truncated or foreign
  // Every key of these sections must be in the file: no fallback to compiled-in values.
  std::optional<YamlReader::CompleteFile> complete;
  complete.emplace();
  // Each section loader throws its own ConfigError; collect them all before giving up.
  // An empty value the document check reported ("<file>:<l>:<c>: a.b: no value") is not
  // reported again by the section loader ("a.b: no value").
  auto already_reported = [&](const std::string& p) {
    const auto colon = p.find(": no value");
    if (colon == std::string::npos) return false;
    const std::string key = ": " + p.substr(0, colon) + ": no value";
    return std::any_of(document.begin(), document.end(),
                       [&](const std::string& d) { return d.find(key) != std::string::npos; });
  };
  auto section = [&](const std::function<void()>& load) {
    try {
      load();
    } catch (const ConfigError& e) {
      for (const auto& p : e.problems())
        if (!already_reported(p)) problems.push_back(fmt::format("{}: {}", path, p));
    }
  };
  section([&] { cfg.model = model::load_model(root["model"]); });
  const int n = cfg.model.n > 0 ? cfg.model.n : 4;
  section([&] { cfg.control = control::load_control_config(root["controller"], n); });
  section([&] { cfg.trajectory = trajectory::load_trajectory_config(root["trajectory"]); });
  section([&] { cfg.plant = sim::load_plant_config(root["plant"]); });
  section([&] {
    ConfigProblems p;
    YamlReader loop(root["loop"], "loop", p.sink());
    if (!loop.valid()) p.sink()->push_back("loop: missing (rate_hz: the control rate)");
    cfg.loop = control::read_executive_config(loop);
    p.finish();
  });
  section([&] { cfg.safety = safety::load_safety_config(root["safety"]); });
  complete.reset();  // `can:` keeps its loader's own rules (drivers/canopen_config.hpp)
  // Checked against the same file's safety.torque.max, as load_can_config_file() does: every
  // run takes its bus description from here (one read of the file), and `dualv config check`
  // reports a can.drives[].max_torque above the safety limit.
  section([&] {
    cfg.can = drivers::load_can_config(root["can"], drivers::safety_torque_max_of(root));
  });
  if (problems.size() == document.size()) {  // every section loaded: cross-check them
    // Programs that pass pre-flight must not trip the safety layer: its limits must be at
    // least as wide as the trajectory's.
    const auto& lim = cfg.trajectory.limits;
    const auto& s = cfg.safety;
    auto outside = [](const safety::Range& r, const trajectory::Interval& i) {
      return i.lo < r.lo || i.hi > r.hi;
    };
    const std::pair<const char*, bool> checks[] = {
        {"safety.workspace.x: must contain trajectory.limits.workspace.x",
         outside(s.workspace.x, lim.workspace.x)},
        {"safety.workspace.y: must contain trajectory.limits.workspace.y",
         outside(s.workspace.y, lim.workspace.y)},
        {"safety.workspace.theta: must contain trajectory.limits.workspace.theta",
         outside(s.workspace.theta, lim.workspace.theta)},
        {"safety.torque.max: must be >= trajectory.limits.max_joint_torque",
         s.torque.max < lim.max_joint_torque},
        {"safety.max_joint_velocity: must be >= trajectory.limits.max_joint_speed",
         s.max_joint_velocity < lim.max_joint_speed},
        {"safety.min_parallel_singularity: must be <= trajectory.limits.min_parallel_singularity",
         s.min_parallel_singularity > lim.min_parallel_singularity},
        {"safety.min_serial_singularity: must be <= trajectory.limits.min_serial_singularity",
         s.min_serial_singularity > lim.min_serial_singularity},
        {"trajectory.streaming.max_speed: must be below safety.max_plate_velocity",
         cfg.trajectory.streaming.max_speed >= s.max_plate_velocity},
        {"trajectory.streaming.max_angular_speed: must be below "
         "safety.max_plate_angular_velocity",
         cfg.trajectory.streaming.max_angular_speed >= s.max_plate_angular_velocity},
    };
    for (const auto& [what, bad] : checks)
      if (bad) problems.push_back(fmt::format("{}: {}", path, what));
    for (auto& p : rate_problems(cfg, "loop.rate_hz")) problems.push_back(std::move(p));
    if (cfg.plant.saturation.peak_torque < s.torque.max)
      problems.push_back(fmt::format(
          "{}: safety.torque.max: must not exceed the drives' peak plant.saturation.peak_torque "
          "= {} N m (got {})",
          path, cfg.plant.saturation.peak_torque, s.torque.max));
  }
  if (!problems.empty()) throw ConfigError(problems);
  cfg.trajectory.limits.loop_period = cfg.period();  // pre-flight at the loop rate
  return cfg;
}

}  // namespace dualv::apps
