#include "control/trajectory/limits.hpp"

#include <fmt/format.h>

#include "common/yaml_reader.hpp"

namespace dualv::trajectory {

namespace {

// Physical ranges (limits.hpp): a Dual-V-sized machine; beyond them a value is a unit mistake.
constexpr double kMaxWorkspace = 2.0;            // [m] |x|, |y| of the plate
constexpr double kMaxAngle = 3.2;                // [rad] |theta|
constexpr double kDrivePeakTorque = 127.0;       // [N m] the ETEL drives (docs/architecture.md)
constexpr double kMaxJointSpeed = 100.0;         // [rad/s]
constexpr double kMaxPlateSpeed = 10.0;          // [m/s]
constexpr double kMaxPlateAcceleration = 1e3;    // [m/s^2]
constexpr double kMaxAngularSpeed = 100.0;       // [rad/s]
constexpr double kMaxAngularAcceleration = 1e4;  // [rad/s^2]

Interval read_interval(YamlReader& r, const std::string& key, double bound) {
  const bool present = r.has(key);
  const std::vector<double> v = r.numbers(key);
  if (!present) return {};
  if (v.size() != 2) {
    r.problem(fmt::format("{}: must be [min, max] (got {} numbers)", r.key_path(key), v.size()));
    return {};
  }
  r.require(v[0] < v[1], key, fmt::format("must have min < max (got [{}, {}])", v[0], v[1]));
  r.require(v[0] >= -bound && v[1] <= bound, key,
            fmt::format("must lie within [{}, {}] (got [{}, {}])", -bound, bound, v[0], v[1]));
  return {v[0], v[1]};
}

}  // namespace

TrajectoryConfig load_trajectory_config(const YAML::Node& trajectory_node_in) {
  // An absent key of a const node is an invalid node that throws on use: read it as null.
  const YAML::Node trajectory_node =
      trajectory_node_in.IsDefined() ? trajectory_node_in : YAML::Node();
  ConfigProblems problems;
  YamlReader root(trajectory_node, "trajectory", problems.sink());
  if (!root.valid()) root.problem("trajectory: missing");
  TrajectoryConfig cfg;

  YamlReader lim = root.child("limits");
  Limits& l = cfg.limits;
  YamlReader ws = lim.child("workspace");
  l.workspace.x = read_interval(ws, "x", kMaxWorkspace);
  l.workspace.y = read_interval(ws, "y", kMaxWorkspace);
  l.workspace.theta = read_interval(ws, "theta", kMaxAngle);
  ws.reject_unknown_keys();
  l.min_parallel_singularity = lim.in_range("min_parallel_singularity", 0.0, 10.0);
  l.min_serial_singularity = lim.in_range("min_serial_singularity", 0.0, 1.0);
  l.max_joint_speed = lim.in_range("max_joint_speed", 1e-3, kMaxJointSpeed);
  l.max_plate_acceleration = lim.in_range("max_plate_acceleration", 1e-3, kMaxPlateAcceleration);
  l.max_plate_angular_acceleration =
      lim.in_range("max_plate_angular_acceleration", 1e-3, kMaxAngularAcceleration);
  l.max_joint_torque = lim.in_range("max_joint_torque", 1e-3, kDrivePeakTorque);
  l.sample_period = lim.in_range("sample_period", 1e-6, 0.1, 5e-4);
  lim.reject_unknown_keys();

  RebaseOptions& b = cfg.rebase;
  YamlReader reb = root.child("rebase");
  b.max_speed = reb.in_range("max_speed", 1e-6, kMaxPlateSpeed);
  b.max_acceleration = reb.in_range("max_acceleration", 1e-6, kMaxPlateAcceleration);
  b.max_angular_speed = reb.in_range("max_angular_speed", 1e-6, kMaxAngularSpeed);
  b.max_angular_acceleration =
      reb.in_range("max_angular_acceleration", 1e-6, kMaxAngularAcceleration);
  b.tolerance = reb.in_range("tolerance", 1e-12, 1e-2, 1e-9);
  reb.reject_unknown_keys();

  // Optional section: a configuration without it streams with the defaults.
  StreamingLimits& st = cfg.streaming;
  const StreamingLimits sd;
  YamlReader str = root.child("streaming", false);
  if (str.valid()) {
    st.max_speed = str.in_range("max_speed", 1e-6, kMaxPlateSpeed, sd.max_speed);
    st.max_acceleration =
        str.in_range("max_acceleration", 1e-6, kMaxPlateAcceleration, sd.max_acceleration);
    st.max_angular_speed =
        str.in_range("max_angular_speed", 1e-6, kMaxAngularSpeed, sd.max_angular_speed);
    st.max_angular_acceleration = str.in_range(
        "max_angular_acceleration", 1e-6, kMaxAngularAcceleration, sd.max_angular_acceleration);
    str.require(st.max_acceleration <= l.max_plate_acceleration, "max_acceleration",
                "must not exceed trajectory.limits.max_plate_acceleration");
    str.require(st.max_angular_acceleration <= l.max_plate_angular_acceleration,
                "max_angular_acceleration",
                "must not exceed trajectory.limits.max_plate_angular_acceleration");
    str.reject_unknown_keys();
  }

  root.reject_unknown_keys();
  problems.finish();
  return cfg;
}

TrajectoryConfig load_trajectory_config_file(const std::string& path) {
  const YAML::Node doc = YamlReader::load_file(path);
  return load_trajectory_config(doc["trajectory"]);
}

}  // namespace dualv::trajectory
