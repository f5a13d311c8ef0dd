#pragma once
// The `safety:` section of the robot configuration (config/dualv.yaml). Every value has a
// checked range; a missing key takes the default below, an unknown key or a value out of
// range throws dualv::ConfigError naming the key (set-up only, never in the cycle).
// Times are in seconds and turned into whole control cycles by SafetyFilter (cycles()).
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <string>

namespace dualv::safety {

struct Range {
  double lo = 0.0;
  double hi = 0.0;
  bool contains(double v) const noexcept { return v >= lo && v <= hi; }  // false for NaN
};

struct SafetyConfig {
  struct Torque {
    double max = 60.0;          // [N m] per motor, absolute clamp (<= the drives' 6072h / peak)
    double max_rate = 30000.0;  // [N m/s] per motor: |tau_k - tau_k-1| <= max_rate * period
  } torque;
  double max_joint_velocity = 12.0;         // [rad/s] every crank (SLS-like, IEC 61800-5-2)
  double max_plate_velocity = 1.0;          // [m/s] |(x_dot, y_dot)|
  double max_plate_angular_velocity = 6.0;  // [rad/s] |theta_dot|
  struct Workspace {
    Range x{-0.12, 0.12};      // [m]
    Range y{0.13, 0.37};       // [m]
    Range theta{-0.45, 0.45};  // [rad]
  } workspace;
  double min_parallel_singularity = 0.1;   // scaled smallest singular value of Jm (kinematics.hpp)
  double min_serial_singularity = 0.1;     // |sin| of the crank-coupler angle, every chain
  double max_tracking_error = 0.005;       // [m] |(x_d - x, y_d - y)| while a program runs
  double max_tracking_error_angle = 0.05;  // [rad] |theta_d - theta|
  double max_encoder_jump = 0.05;          // [rad] position step between two fresh samples
  struct Ss1 {
    double max_time = 0.5;              // [s] standstill must be reached within this, then STO
    double damping = 20.0;              // [N m s/rad] tau = -damping * q_dot (same for every joint)
    double max_torque = 40.0;           // [N m] braking torque clamp (<= torque.max)
    double standstill_velocity = 0.05;  // [rad/s] every |q_dot| below this ...
    double standstill_time = 0.01;      // [s] ... for this long: standstill, STO
  } ss1;
  struct Watchdogs {
    int max_consecutive_deadline_misses = 3;  // this many consecutive misses: STO
    int stale_feedback_cycles = 3;            // this many cycles without fresh feedback: STO
    double command_stream_timeout = 0.1;      // [s] streaming mode: no command this long: SS1
    int reset_fault_cycles = 20;              // a reset sends CiA 402 fault reset this long
  } watchdogs;
};

// Reads the `safety:` map (an absent or null node gives the defaults). Throws
// dualv::ConfigError with every problem, each naming its key ("safety.torque.max: ...").
SafetyConfig load_safety_config(const YAML::Node& safety_node);

// Problems of a config built in code (the same rules as the loader); empty when valid.
std::string validate(const SafetyConfig& config);

}  // namespace dualv::safety
