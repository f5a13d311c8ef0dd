// One control cycle (read, estimate, sample, control law, projection, write) allocates
// nothing: counted over 10,000 cycles against the in-process plant.
#include <gtest/gtest.h>

#include "apps/experiment/robot_config.hpp"
#include "control/loop/control_cycle.hpp"
#include "control/trajectory/program.hpp"
#include "sim/plant.hpp"
#include "sim/sim_actuator_set.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::apps {
namespace {

TEST(ControlCycle, TenThousandCyclesAllocateNothing) {
  const RobotConfig cfg = load_robot_config(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  trajectory::ProgramContext ctx;
  ctx.start = ctx.home = cfg.model.home;
  const trajectory::Program program =
      trajectory::load_program_file(std::string(DUALV_SOURCE_DIR) + "/config/paper.yaml", ctx);
  sim::Plant plant(cfg.model, cfg.plant);
  plant.reset(cfg.model.home);
  sim::SimActuatorSet io(plant);
  control::ControlCycle cycle(cfg.model, cfg.control, {cfg.period(), 2.0});
  cycle.start(io, program, cfg.trajectory.rebase);
  control::CycleRecord rec;
  const long before = dualv::test::allocation_count();
  int bad = 0;
  for (int k = 0; k < 10000; ++k) {  // 10 s: the whole program, then holding the end pose
    if (cycle.step(io, rec) != control::CycleStatus::kOk) ++bad;
    plant.advance(cfg.period());
  }
  EXPECT_EQ(dualv::test::allocation_count() - before, 0);
  EXPECT_EQ(bad, 0);
  EXPECT_EQ(cycle.phase(), control::CyclePhase::kHolding);
  EXPECT_TRUE(rec.control.tau.allFinite());
}

}  // namespace
}  // namespace dualv::apps
