// The machine's supervisor side (apps/experiment/machine.hpp) on simulated time.
#include "apps/experiment/machine.hpp"

#include "apps/experiment/closed_loop.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "control/trajectory/program.hpp"
#include "safety/estop_latch.hpp"
#include "sim/plant.hpp"
#include "sim/sim_actuator_set.hpp"

namespace dualv::apps {
namespace {

const std::string kConfig = std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml";
const std::string kPaper = std::string(DUALV_SOURCE_DIR) + "/config/paper.yaml";

// A stop latched while idle refuses the next start, and the refusal names the stop's cause:
// `dualv selftest` and `dualv run` print it, and a stop that latched between the caller's last
// look and the start (a timing watchdog on a slow machine) is then told apart from any other.
TEST(Machine, AStartRefusedByALatchedStopNamesItsCause) {
  const RobotConfig cfg = load_robot_config(kConfig);
  trajectory::ProgramContext ctx;
  ctx.start = ctx.home = cfg.model.home;
  const trajectory::Program program = trajectory::load_program_file(kPaper, ctx);
  sim::Plant plant(cfg.model, cfg.plant);
  plant.reset(cfg.model.home);
  sim::SimActuatorSet io(plant);
  MachineOptions options;
  options.pacing = Pacing::kSimulated;
  Machine machine(cfg, io, options, &plant);
  machine.start();
  machine.executor().request_estop(safety::StopSource::kCli);
  for (int k = 0; k < 5; ++k) machine.pump();
  ASSERT_NE(machine.snapshot().latched, 0u);

  std::string what;
  try {
    (void)machine.begin(program, paper_variants().front(), 0.0);
  } catch (const std::runtime_error& e) {
    what = e.what();
  }
  EXPECT_NE(what.find("a stop is latched"), std::string::npos) << what;
  const std::string cause = safety::to_string(safety::fault_of(safety::StopSource::kCli));
  EXPECT_NE(what.find("(latched: " + cause + ")"), std::string::npos) << what;
}

}  // namespace
}  // namespace dualv::apps
