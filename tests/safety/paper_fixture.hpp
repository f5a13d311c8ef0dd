#pragma once
// The shipped robot configuration and the paper program, loaded once, for the closed-loop
// safety scenarios (in-process and over the CAN rig).
#include <string>

#include "apps/experiment/robot_config.hpp"
#include "control/trajectory/program.hpp"

namespace dualv::safety::test {

inline const apps::RobotConfig& robot() {
  static const apps::RobotConfig cfg =
      apps::load_robot_config(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  return cfg;
}

inline const trajectory::Program& paper() {
  static const trajectory::Program p = [] {
    trajectory::ProgramContext ctx;
    ctx.start = ctx.home = robot().model.home;
    return trajectory::load_program_file(std::string(DUALV_SOURCE_DIR) + "/config/paper.yaml", ctx);
  }();
  return p;
}

}  // namespace dualv::safety::test
