#pragma once
// Everything `dualv` reads from a robot configuration file (config/dualv.yaml), loaded
// section by section; every problem of every section is reported at once, each naming the
// file, the key path and the reason, and nothing is returned half-loaded.
//
// A configuration file must be complete (issue 14): every section of kRequiredSections
// present, every key of model/controller/trajectory/plant/loop/safety given (the defaults
// live in the shipped config/dualv.yaml, not in code; optional tuning keys of `loop:` and a
// chain's per-link overrides stay optional), no unknown section or key, no duplicate key, no
// empty value, every number finite and in its documented physical range, and the sections
// consistent with each other (see load_robot_config()). `can:` is checked by its own loader
// (drivers/canopen_config.hpp) in every run, in-process ones included.
#include <array>
#include <string>
#include <vector>

#include "control/controller/controller.hpp"
#include "control/loop/periodic_executive.hpp"
#include "control/model/model.hpp"
#include "control/trajectory/limits.hpp"
#include "drivers/canopen_config.hpp"
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
  safety::SafetyConfig safety;
  drivers::CanConfig can;
  double rate_hz() const noexcept { return 1e9 / static_cast<double>(loop.period_ns); }
  double period() const noexcept { return static_cast<double>(loop.period_ns) * 1e-9; }
};

// The sections a configuration file must have, in the order of config/dualv.yaml.
inline constexpr std::array<const char*, 7> kRequiredSections = {
    "model", "trajectory", "plant", "controller", "loop", "can", "safety"};

// Throws dualv::ConfigError listing every problem, each prefixed with the file name.
RobotConfig load_robot_config(const std::string& path);
// Every problem of the file (empty when it loads), for `dualv config check`.
std::vector<std::string> check_robot_config(const std::string& path);

// `dualv run --rate HZ`: the loop at another rate than the file's loop.rate_hz. The SYNC
// period follows (the SYNC is the control cycle: can.sync.period = 1 / rate), pre-flight
// samples at the new period, and every check that depends on the rate runs again, as at load:
// the velocity filter below Nyquist, the plant's integration rate, the times the safety layer
// counts in whole cycles (at least one cycle each), the `can:` rules on the SYNC period
// (can.rpdo_deadline, can.timeouts.transition) and, when the run drives the bus (`on_bus`),
// the worst-case bus load within can.max_bus_load. Throws ConfigError naming the file, the
// key and --rate; `cfg` is unchanged then.
void override_rate(RobotConfig& cfg, double rate_hz, bool on_bus);

}  // namespace dualv::apps
