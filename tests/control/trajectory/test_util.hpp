#pragma once
// Shared helpers for the control/trajectory tests.
#include <yaml-cpp/yaml.h>

#include <string>

#include "control/config/model_config.hpp"
#include "control/trajectory/limits.hpp"
#include "control/trajectory/program.hpp"

namespace dualv::trajectory::test {

inline const Pose kHome(0.0, 0.25, 0.0);

inline std::string source_path(const std::string& rel) {
  return std::string(DUALV_SOURCE_DIR) + "/" + rel;
}

// Program from inline YAML (the text of the `program:` map's parent document).
inline Program load_yaml(const std::string& text, const ProgramContext& ctx) {
  const YAML::Node doc = YAML::Load(text);
  return load_program(doc["program"], ctx);
}

inline ProgramContext home_context() {
  ProgramContext ctx;
  ctx.start = kHome;
  ctx.home = kHome;
  return ctx;
}

// The paper's experiment (config/paper.yaml), started at home.
inline Program paper_program() {
  return load_program_file(source_path("config/paper.yaml"), home_context());
}

// Maximum absolute component difference.
template <class A, class B>
double max_diff(const A& a, const B& b) {
  return (a - b).cwiseAbs().maxCoeff();
}

inline const model::Model& dualv_model() {
  static const model::Model m = model::load_model_file(source_path("config/dualv.yaml"));
  return m;
}

inline TrajectoryConfig dualv_trajectory_config() {
  return load_trajectory_config_file(source_path("config/dualv.yaml"));
}

// Limits nothing can violate: tests tighten one at a time.
inline Limits loose_limits() {
  Limits l;
  l.workspace = Workspace{};
  l.min_parallel_singularity = 0.0;
  l.min_serial_singularity = 0.0;
  l.max_joint_speed = 1e9;
  l.max_plate_acceleration = 1e9;
  l.max_plate_angular_acceleration = 1e9;
  l.max_joint_torque = 1e9;
  l.sample_period = 5e-4;
  return l;
}

}  // namespace dualv::trajectory::test
