#pragma once
// Everything `dualv` reads from a robot configuration file (config/dualv.yaml), loaded
// section by section; every problem of every section is reported at once, each with its
// key, and nothing is returned half-loaded.
#include <string>

#include "control/controller/controller.hpp"
#include "control/loop/periodic_executive.hpp"
#include "control/model/model.hpp"
#include "control/trajectory/limits.hpp"
#include "safety/safety_config.hpp"
#include "sim/plant.hpp"

namespace dualv::apps {

struct RobotConfig {
  std::string path;
  model::Model model;
  control::ControlSetup control;
  trajectory::TrajectoryConfig trajectory;
  sim::PlantConfig plant;
  control::ExecutiveConfig loop;
  safety::SafetyConfig safety;  // `safety:` (optional section: defaults when absent)
  double rate_hz() const noexcept { return 1e9 / static_cast<double>(loop.period_ns); }
  double period() const noexcept { return static_cast<double>(loop.period_ns) * 1e-9; }
};

// Throws dualv::ConfigError listing every problem, prefixed with the file name.
RobotConfig load_robot_config(const std::string& path);

}  // namespace dualv::apps
