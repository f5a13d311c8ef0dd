// The simulator's cycle allocates nothing: operator new is counted
// (tests/support/allocation_counter.cpp replaces it for this binary) over 10,000 cycles with every
// realism knob on.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/plant.hpp"
#include "sim/sim_actuator_set.hpp"
#include "tests/sim/sim_fixture.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::sim {
namespace {

double* volatile g_sink = nullptr;  // keeps the compiler from eliding the new below

TEST(PlantAllocation, CounterSeesAnAllocation) {
  // The counter itself works: otherwise the zero below would prove nothing.
  dualv::test::start_counting();
  g_sink = new double(1.0);
  const long n = dualv::test::stop_counting();
  delete g_sink;
  EXPECT_EQ(n, 1);
}

TEST(PlantAllocation, TenThousandCyclesAllocateNothing) {
  Plant plant(test::dual_v(), load_plant_config_file(test::config_file()));
  SimActuatorSet set(plant);
  drivers::ActuatorFeedback fb;
  drivers::ActuatorCommand cmd;
  cmd.n = 4;
  model::JointVector tau(4);
  dualv::test::start_counting();
  for (int k = 0; k < 10000; ++k) {
    set.read(fb);
    const double s = std::sin(0.01 * k);
    cmd.request = k == 0 ? drivers::DriveRequest::kEnable : drivers::DriveRequest::kHold;
    for (int i = 0; i < 4; ++i) cmd.torque[i] = (i % 2 ? -1.0 : 1.0) * s;
    set.write(cmd);
    plant.advance(1e-3);
    tau = plant.output().tau_applied;
    plant.energy();
  }
  const long allocations = dualv::test::stop_counting();
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(plant.status(), PlantStatus::kOk);
  EXPECT_EQ(plant.output().cycle, 10000u);
}

}  // namespace
}  // namespace dualv::sim
