#pragma once
// Trajectory limits and start-up options, read from the `trajectory:` section of a dualv
// configuration (config/dualv.yaml). Set-up code: loading throws dualv::ConfigError naming
// every bad key; nothing is returned half-read.
#include <yaml-cpp/yaml.h>

#include <string>

namespace dualv::trajectory {

struct Interval {
  double lo = 0.0;
  double hi = 0.0;
  bool contains(double v) const noexcept { return v >= lo && v <= hi; }
};

// Box the plate pose must stay in [m, m, rad].
struct Workspace {
  Interval x{-1e9, 1e9};
  Interval y{-1e9, 1e9};
  Interval theta{-1e9, 1e9};
};

// Everything pre-flight checks (preflight.hpp). Keys are trajectory.limits.<name>.
struct Limits {
  Workspace workspace;
  double min_parallel_singularity = 0.0;        // singularity_measures().parallel lower bound
  double min_serial_singularity = 0.0;          // singularity_measures().min_serial lower bound
  double max_joint_speed = 1e9;                 // |q_dot_i| [rad/s]
  double max_plate_acceleration = 1e9;          // |(x_dd, y_dd)| [m/s^2]
  double max_plate_angular_acceleration = 1e9;  // |theta_dd| [rad/s^2]
  double max_joint_torque = 1e9;                // |tau_i| from the inverse dynamics [N m]
  double sample_period = 5e-4;                  // pre-flight sampling step [s]
  // The control loop's period [s] (1 / loop.rate_hz, set by apps/experiment/robot_config.cpp;
  // not a key of `trajectory:`): pre-flight also samples the program as the loop will and
  // checks the joint speed between two cycles. 0: not checked.
  double loop_period = 0.0;
};

// The move that joins the robot's actual pose to a program's first pose (program.hpp rebase()):
// its duration is the shortest quintic within these limits (at least the file's duration).
struct RebaseOptions {
  double max_speed = 0.05;                // [m/s]
  double max_acceleration = 0.5;          // [m/s^2]
  double max_angular_speed = 0.5;         // [rad/s]
  double max_angular_acceleration = 5.0;  // [rad/s^2]
  double tolerance = 1e-9;                // poses closer than this (m, rad) need no joining move
};

// The streaming reference (streaming_reference.hpp): how fast the plate may follow streamed
// setpoints. Keys are trajectory.streaming.<name>; the accelerations must not exceed
// trajectory.limits' and the speeds the safety layer's plate velocity limits.
struct StreamingLimits {
  double max_speed = 0.1;                 // |(x_dot, y_dot)| [m/s]
  double max_acceleration = 1.0;          // |(x_dd, y_dd)| [m/s^2]
  double max_angular_speed = 0.5;         // |theta_dot| [rad/s]
  double max_angular_acceleration = 5.0;  // |theta_dd| [rad/s^2]
};

struct TrajectoryConfig {
  Limits limits;
  RebaseOptions rebase;
  StreamingLimits streaming;
};

// Reads the `trajectory:` map (path "trajectory").
TrajectoryConfig load_trajectory_config(const YAML::Node& trajectory_node);
// Reads `trajectory:` from a whole configuration file.
TrajectoryConfig load_trajectory_config_file(const std::string& path);

}  // namespace dualv::trajectory
