#include "safety/safety_config.hpp"

#include <fmt/format.h>

#include <vector>

#include "common/config_error.hpp"
#include "common/yaml_reader.hpp"

namespace dualv::safety {

namespace {

// Ranges every value must lie in: wide enough for any n-RRR machine of this size class,
// narrow enough to catch unit mistakes (N m vs mN m, rad vs deg, s vs ms).
constexpr double kDrivePeakTorque = 127.0;  // [N m] the Dual-V's ETEL drives (docs/architecture.md)

Range read_range(YamlReader& r, const std::string& key, Range fallback, double lo, double hi) {
  const bool present = r.has(key);
  const std::vector<double> v = r.numbers(key, std::vector<double>{fallback.lo, fallback.hi});
  if (!present) return fallback;
  if (v.size() != 2) {
    r.problem(fmt::format("{}: must be [min, max] (got {} numbers)", r.key_path(key), v.size()));
    return fallback;
  }
  r.require(v[0] < v[1], key, fmt::format("must have min < max (got [{}, {}])", v[0], v[1]));
  r.require(v[0] >= lo && v[1] <= hi, key,
            fmt::format("must lie within [{}, {}] (got [{}, {}])", lo, hi, v[0], v[1]));
  return {v[0], v[1]};
}

void check(std::vector<std::string>& out, bool ok, const char* key, const std::string& rule,
           double got) {
  if (!ok) out.push_back(fmt::format("safety.{}: {} (got {})", key, rule, got));
}

std::vector<std::string> problems_of(const SafetyConfig& c) {
  std::vector<std::string> p;
  check(p, c.torque.max > 0.0 && c.torque.max <= kDrivePeakTorque, "torque.max",
        fmt::format("must be in (0, {}] N m (the drives' peak)", kDrivePeakTorque), c.torque.max);
  check(p, c.torque.max_rate >= 100.0 && c.torque.max_rate <= 1e6, "torque.max_rate",
        "must be in [100, 1e6] N m/s", c.torque.max_rate);
  check(p, c.max_joint_velocity > 0.0 && c.max_joint_velocity <= 100.0, "max_joint_velocity",
        "must be in (0, 100] rad/s", c.max_joint_velocity);
  check(p, c.max_plate_velocity > 0.0 && c.max_plate_velocity <= 10.0, "max_plate_velocity",
        "must be in (0, 10] m/s", c.max_plate_velocity);
  check(p, c.max_plate_angular_velocity > 0.0 && c.max_plate_angular_velocity <= 100.0,
        "max_plate_angular_velocity", "must be in (0, 100] rad/s", c.max_plate_angular_velocity);
  check(p, c.min_parallel_singularity >= 0.0 && c.min_parallel_singularity <= 10.0,
        "min_parallel_singularity", "must be in [0, 10]", c.min_parallel_singularity);
  check(p, c.min_serial_singularity >= 0.0 && c.min_serial_singularity < 1.0,
        "min_serial_singularity", "must be in [0, 1)", c.min_serial_singularity);
  check(p, c.max_tracking_error > 0.0 && c.max_tracking_error <= 0.5, "max_tracking_error",
        "must be in (0, 0.5] m", c.max_tracking_error);
  check(p, c.max_tracking_error_angle > 0.0 && c.max_tracking_error_angle <= 3.2,
        "max_tracking_error_angle", "must be in (0, 3.2] rad", c.max_tracking_error_angle);
  check(p, c.max_encoder_jump > 0.0 && c.max_encoder_jump <= 3.2, "max_encoder_jump",
        "must be in (0, 3.2] rad", c.max_encoder_jump);
  check(p, c.ss1.max_time > 0.0 && c.ss1.max_time <= 10.0, "ss1.max_time", "must be in (0, 10] s",
        c.ss1.max_time);
  check(p, c.ss1.damping >= 0.0 && c.ss1.damping <= 1000.0, "ss1.damping",
        "must be in [0, 1000] N m s/rad", c.ss1.damping);
  check(p, c.ss1.max_torque >= 0.0 && c.ss1.max_torque <= c.torque.max, "ss1.max_torque",
        fmt::format("must be in [0, torque.max = {}] N m", c.torque.max), c.ss1.max_torque);
  check(p, c.ss1.standstill_velocity > 0.0 && c.ss1.standstill_velocity <= 1.0,
        "ss1.standstill_velocity", "must be in (0, 1] rad/s", c.ss1.standstill_velocity);
  check(p, c.ss1.standstill_time >= 0.0 && c.ss1.standstill_time < c.ss1.max_time,
        "ss1.standstill_time", "must be in [0, ss1.max_time)", c.ss1.standstill_time);
  check(p,
        c.watchdogs.max_consecutive_deadline_misses >= 1 &&
            c.watchdogs.max_consecutive_deadline_misses <= 1000,
        "watchdogs.max_consecutive_deadline_misses", "must be in [1, 1000]",
        c.watchdogs.max_consecutive_deadline_misses);
  check(p, c.watchdogs.stale_feedback_cycles >= 1 && c.watchdogs.stale_feedback_cycles <= 1000,
        "watchdogs.stale_feedback_cycles", "must be in [1, 1000]",
        c.watchdogs.stale_feedback_cycles);
  check(p, c.watchdogs.command_stream_timeout > 0.0 && c.watchdogs.command_stream_timeout <= 10.0,
        "watchdogs.command_stream_timeout", "must be in (0, 10] s",
        c.watchdogs.command_stream_timeout);
  check(p, c.watchdogs.reset_fault_cycles >= 1 && c.watchdogs.reset_fault_cycles <= 10000,
        "watchdogs.reset_fault_cycles", "must be in [1, 10000]", c.watchdogs.reset_fault_cycles);
  auto range_ok = [&](const Range& r, const char* key) {
    if (!(r.lo < r.hi)) p.push_back(fmt::format("safety.{}: must have min < max", key));
  };
  range_ok(c.workspace.x, "workspace.x");
  range_ok(c.workspace.y, "workspace.y");
  range_ok(c.workspace.theta, "workspace.theta");
  return p;
}

}  // namespace

std::string validate(const SafetyConfig& config) {
  std::string out;
  for (const auto& p : problems_of(config)) out += (out.empty() ? "" : "\n") + p;
  return out;
}

SafetyConfig load_safety_config(const YAML::Node& node_in) {
  const YAML::Node node = node_in.IsDefined() ? node_in : YAML::Node();
  ConfigProblems problems;
  YamlReader root(node, "safety", problems.sink());
  SafetyConfig c;
  const SafetyConfig d;
  {
    YamlReader t = root.child("torque", false);
    c.torque.max = t.number("max", d.torque.max);
    c.torque.max_rate = t.number("max_rate", d.torque.max_rate);
    t.reject_unknown_keys();
  }
  c.max_joint_velocity = root.number("max_joint_velocity", d.max_joint_velocity);
  c.max_plate_velocity = root.number("max_plate_velocity", d.max_plate_velocity);
  c.max_plate_angular_velocity =
      root.number("max_plate_angular_velocity", d.max_plate_angular_velocity);
  {
    YamlReader w = root.child("workspace", false);
    c.workspace.x = read_range(w, "x", d.workspace.x, -2.0, 2.0);
    c.workspace.y = read_range(w, "y", d.workspace.y, -2.0, 2.0);
    c.workspace.theta = read_range(w, "theta", d.workspace.theta, -3.2, 3.2);
    w.reject_unknown_keys();
  }
  c.min_parallel_singularity = root.number("min_parallel_singularity", d.min_parallel_singularity);
  c.min_serial_singularity = root.number("min_serial_singularity", d.min_serial_singularity);
  c.max_tracking_error = root.number("max_tracking_error", d.max_tracking_error);
  c.max_tracking_error_angle = root.number("max_tracking_error_angle", d.max_tracking_error_angle);
  c.max_encoder_jump = root.number("max_encoder_jump", d.max_encoder_jump);
  {
    YamlReader s = root.child("ss1", false);
    c.ss1.max_time = s.number("max_time", d.ss1.max_time);
    c.ss1.damping = s.number("damping", d.ss1.damping);
    c.ss1.max_torque = s.number("max_torque", d.ss1.max_torque);
    c.ss1.standstill_velocity = s.number("standstill_velocity", d.ss1.standstill_velocity);
    c.ss1.standstill_time = s.number("standstill_time", d.ss1.standstill_time);
    s.reject_unknown_keys();
  }
  {
    YamlReader w = root.child("watchdogs", false);
    c.watchdogs.max_consecutive_deadline_misses =
        w.integer("max_consecutive_deadline_misses", d.watchdogs.max_consecutive_deadline_misses);
    c.watchdogs.stale_feedback_cycles =
        w.integer("stale_feedback_cycles", d.watchdogs.stale_feedback_cycles);
    c.watchdogs.command_stream_timeout =
        w.number("command_stream_timeout", d.watchdogs.command_stream_timeout);
    c.watchdogs.reset_fault_cycles =
        w.integer("reset_fault_cycles", d.watchdogs.reset_fault_cycles);
    w.reject_unknown_keys();
  }
  root.reject_unknown_keys();
  for (auto& p : problems_of(c)) problems.sink()->push_back(std::move(p));
  problems.finish();
  return c;
}

}  // namespace dualv::safety
