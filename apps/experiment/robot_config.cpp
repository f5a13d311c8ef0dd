#include "apps/experiment/robot_config.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <functional>

#include "common/config_error.hpp"
#include "common/yaml_reader.hpp"
#include "control/model/model_config.hpp"

namespace dualv::apps {

RobotConfig load_robot_config(const std::string& path) {
  const YAML::Node root = YamlReader::load_file(path);
  RobotConfig cfg;
  cfg.path = path;
  std::vector<std::string> problems;
  // Each section loader throws its own ConfigError; collect them all before giving up.
  auto section = [&](const std::function<void()>& load) {
    try {
      load();
    } catch (const ConfigError& e) {
      for (const auto& p : e.problems()) problems.push_back(fmt::format("{}: {}", path, p));
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
  if (problems.empty()) {
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
  }
  const char* known[] = {"model",  "controller", "trajectory", "plant", "loop",
                         "safety", "can",        "lcm",        "drives"};
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (std::find(std::begin(known), std::end(known), key) == std::end(known))
      problems.push_back(fmt::format("{}: {}: unknown section", path, key));
  }
  if (!problems.empty()) throw ConfigError(problems);
  return cfg;
}

}  // namespace dualv::apps
