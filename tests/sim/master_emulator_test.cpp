// The real CANopen master (drivers/canopen_setup.hpp boot + CanopenActuatorSet) against
// the drive emulator, in-process over CAN frames (InProcessCanRig), in simulated time:
// the whole wire contract exercised from both ends without a fake on either side.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "drivers/canopen/clock.hpp"
#include "drivers/canopen/waiter.hpp"
#include "drivers/canopen_actuator_set.hpp"
#include "drivers/canopen_config.hpp"
#include "drivers/canopen_setup.hpp"
#include "sim/in_process_can_rig.hpp"
#include "tests/sim/sim_fixture.hpp"

namespace dualv::sim {
namespace {

// The master's blocking waits step the rig (and the master's clock with it) in 0.1 ms.
class RigWaiter final : public drivers::canopen::Waiter {
 public:
  RigWaiter(InProcessCanRig& rig, drivers::canopen::ManualClock& clock)
      : rig_(rig), clock_(clock) {}
  void wait_until(std::uint64_t deadline_ns) override {
    const std::uint64_t now = rig_.now_ns();
    rig_.step(deadline_ns > now ? std::min<std::uint64_t>(deadline_ns - now, 100'000) : 0);
    clock_.set_ns(rig_.now_ns());
  }

 private:
  InProcessCanRig& rig_;
  drivers::canopen::ManualClock& clock_;
};

class MasterEmulator : public ::testing::Test {
 protected:
  MasterEmulator()
      : can(drivers::load_can_config_file(test::config_file())),
        rig(test::dual_v(), load_plant_config_file(test::config_file()), can),
        waiter(rig, clock) {}
  void boot() {
    actuators = drivers::boot_actuator_set(rig.master_bus(), clock, waiter, can);
    ASSERT_NE(actuators, nullptr);
  }
  // One control cycle: read -> (PD on the joint angles) -> write, then the bus and plant.
  drivers::IoStatus cycle(drivers::DriveRequest request) {
    const drivers::IoStatus r = actuators->read(fb);
    drivers::ActuatorCommand cmd;
    cmd.n = 4;
    cmd.request = request;
    for (int i = 0; i < 4; ++i) {
      const double q = fb.drive[static_cast<std::size_t>(i)].position;
      if (!have_home) home[static_cast<std::size_t>(i)] = q;
      const double dq = (q - prev[static_cast<std::size_t>(i)]) / 1e-3;
      prev[static_cast<std::size_t>(i)] = q;
      cmd.torque[static_cast<std::size_t>(i)] =
          std::clamp(-200.0 * (q - home[static_cast<std::size_t>(i)]) - 2.0 * dq, -20.0, 20.0);
    }
    have_home = true;
    actuators->write(cmd);
    rig.step(can.sync_period_ns);
    clock.set_ns(rig.now_ns());
    return r;
  }

  drivers::CanConfig can;
  InProcessCanRig rig;
  drivers::canopen::ManualClock clock;
  RigWaiter waiter;
  std::unique_ptr<drivers::CanopenActuatorSet> actuators;
  drivers::ActuatorFeedback fb;
  std::array<double, 4> home{}, prev{};
  bool have_home = false;
};

TEST_F(MasterEmulator, BootsEnablesAndHoldsThePose) {
  boot();
  for (int i = 0; i < 4; ++i) {
    const EmulatedDriveStatus s = rig.emulator().status(i);
    EXPECT_EQ(s.nmt, EmulatedNmt::kOperational) << "drive " << i;
    std::uint32_t raw = 0;
    ASSERT_TRUE(rig.emulator().read_object(i, fw::od::kModesOfOperation.index, 0, raw));
    EXPECT_EQ(raw, 10u);
  }
  for (int k = 0; k < 20; ++k) cycle(drivers::DriveRequest::kEnable);
  for (int k = 0; k < 500; ++k) cycle(drivers::DriveRequest::kHold);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(rig.emulator().status(i).state, fw::Cia402State::kOperationEnabled) << i;
    EXPECT_EQ(fb.drive[static_cast<std::size_t>(i)].state, drivers::DriveState::kEnabled) << i;
    EXPECT_NEAR(fb.drive[static_cast<std::size_t>(i)].position, home[static_cast<std::size_t>(i)],
                0.01);
    EXPECT_NEAR(fb.drive[static_cast<std::size_t>(i)].position, rig.plant().output().q[i], 1e-5);
  }
  EXPECT_EQ(rig.plant().status(), PlantStatus::kOk);
}

TEST_F(MasterEmulator, EstopInputStopsEveryDriveAndIsReported) {
  boot();
  for (int k = 0; k < 20; ++k) cycle(drivers::DriveRequest::kEnable);
  rig.emulator().press_estop(true);
  bool seen = false;
  for (int k = 0; k < 200; ++k) {
    cycle(drivers::DriveRequest::kHold);
    seen = seen || fb.drive[0].stop_input;
  }
  EXPECT_TRUE(seen);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(rig.emulator().status(i).torque_nm, 0.0);
    EXPECT_NE(fb.drive[static_cast<std::size_t>(i)].state, drivers::DriveState::kEnabled);
  }
}

}  // namespace
}  // namespace dualv::sim
