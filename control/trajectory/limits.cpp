#include "control/trajectory/limits.hpp"

#include <fmt/format.h>

#include "common/yaml_reader.hpp"

namespace dualv::trajectory {

namespace {

Interval read_interval(YamlReader& r, const std::string& key) {
  const bool present = r.has(key);
  const std::vector<double> v = r.numbers(key);
  if (!present) return {};
  if (v.size() != 2) {
    r.problem(fmt::format("{}: must be [min, max] (got {} numbers)", r.key_path(key), v.size()));
    return {};
  }
  r.require(v[0] < v[1], key, fmt::format("must have min < max (got [{}, {}])", v[0], v[1]));
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
  l.workspace.x = read_interval(ws, "x");
  l.workspace.y = read_interval(ws, "y");
  l.workspace.theta = read_interval(ws, "theta");
  ws.reject_unknown_keys();
  l.min_parallel_singularity = lim.non_negative("min_parallel_singularity");
  l.min_serial_singularity = lim.in_range("min_serial_singularity", 0.0, 1.0);
  l.max_joint_speed = lim.positive("max_joint_speed");
  l.max_plate_acceleration = lim.positive("max_plate_acceleration");
  l.max_plate_angular_acceleration = lim.positive("max_plate_angular_acceleration");
  l.max_joint_torque = lim.positive("max_joint_torque");
  l.sample_period = lim.in_range("sample_period", 1e-6, 0.1, 5e-4);
  lim.reject_unknown_keys();

  RebaseOptions& b = cfg.rebase;
  YamlReader reb = root.child("rebase");
  b.max_speed = reb.positive("max_speed");
  b.max_acceleration = reb.positive("max_acceleration");
  b.max_angular_speed = reb.positive("max_angular_speed");
  b.max_angular_acceleration = reb.positive("max_angular_acceleration");
  b.tolerance = reb.positive("tolerance", 1e-9);
  reb.reject_unknown_keys();

  // Optional section: a configuration without it streams with the defaults.
  StreamingLimits& st = cfg.streaming;
  const StreamingLimits sd;
  YamlReader str = root.child("streaming", false);
  if (str.valid()) {
    st.max_speed = str.positive("max_speed", sd.max_speed);
    st.max_acceleration = str.positive("max_acceleration", sd.max_acceleration);
    st.max_angular_speed = str.positive("max_angular_speed", sd.max_angular_speed);
    st.max_angular_acceleration =
        str.positive("max_angular_acceleration", sd.max_angular_acceleration);
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
