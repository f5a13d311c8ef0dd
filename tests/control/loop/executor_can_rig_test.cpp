// The one loop over CANopen frames with the SHIPPED configuration, unchanged: the master boots
// the four emulated drives on the in-process rig (sim/in_process_can_rig.hpp), the executor
// idles, then runs the paper program. Simulated time, deterministic. Before the loop existed,
// the drives' RPDO deadline (can.rpdo_deadline, 10 ms) expired while the service waited for a
// start and the program went to STO in its first cycle; here the wire is checked for it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "control/loop/executor.hpp"
#include "drivers/canopen_config.hpp"
#include "drivers/canopen_setup.hpp"
#include "firmware_if/firmware_if.hpp"
#include "safety/fault_log.hpp"
#include "sim/in_process_can_rig.hpp"
#include "tests/safety/paper_fixture.hpp"
#include "tests/support/can_rig_time.hpp"

namespace dualv::control {
namespace {

using safety::test::paper;
using safety::test::robot;

using dualv::test::RigClock;
using dualv::test::RigWaiter;

TEST(ExecutorOnCan, IdlesFiveSecondsWithTheShippedConfigThenRunsThePaperProgram) {
  const drivers::CanConfig can = drivers::load_can_config_file(robot().path);
  ASSERT_EQ(can.rpdo_deadline_ns, 10'000'000u);  // config/dualv.yaml as shipped
  sim::InProcessCanRig rig(robot().model, robot().plant, can, 4096);
  RigClock clock(rig);
  RigWaiter waiter(rig);
  auto drives = drivers::boot_actuator_set(rig.master_bus(), clock, waiter, can);
  ExecutorConfig ec;
  ec.cycle = {robot().period(), 2.0, robot().safety};
  Executor ex(robot().model, robot().control, ec, *drives);

  // The wire, as a monitor on the bus sees it: the time between consecutive SYNCs and the
  // largest target torque of any RPDO.
  std::uint64_t last_sync = 0, longest_sync_gap = 0;
  double max_torque = 0.0;
  int syncs = 0;
  auto watch = [&] {
    fw::CanFrame f;
    while (rig.monitor_bus().receive(f) == drivers::BusStatus::kOk) {
      if (f.id == 0x080) {
        if (syncs++ > 0) longest_sync_gap = std::max(longest_sync_gap, rig.now_ns() - last_sync);
        last_sync = rig.now_ns();
      }
      if (f.id >= 0x201 && f.id <= 0x204 && f.dlc >= 4) {
        const auto c = fw::decode_rpdo1(f);
        ASSERT_TRUE(c.ok());
        max_torque = std::max(
            max_torque,
            std::abs(fw::per_mille_to_nm(c->target_torque, can.drives[f.id - 0x201].rated_torque)));
      }
    }
  };
  watch();  // boot and priming frames
  syncs = 0;
  std::vector<LoopEvent> events;
  std::int64_t cycle = 0;
  auto step = [&] {
    CycleInfo info;
    info.cycle = cycle++;
    info.period_ns = robot().loop.period_ns;
    ex.step(info);
    rig.step(static_cast<std::uint64_t>(robot().loop.period_ns));
    watch();
    LoopEvent e;
    while (ex.poll_event(e)) events.push_back(e);
    ex.collect();
  };
  auto has = [&](LoopEvent::Kind k) {
    return std::any_of(events.begin(), events.end(),
                       [&](const LoopEvent& e) { return e.kind == k; });
  };
  const int idle_cycles = static_cast<int>(5.0 / robot().period());
  for (int k = 0; k < idle_cycles; ++k) step();
  EXPECT_EQ(ex.snapshot().mode, LoopMode::kIdle);
  EXPECT_EQ(ex.snapshot().safety, safety::SafetyState::kDisabled) << "stopped while idle";
  EXPECT_EQ(ex.snapshot().latched, 0u);
  EXPECT_EQ(syncs, idle_cycles);  // a SYNC every cycle while idle
  for (int i = 0; i < 4; ++i) {   // the drives saw nothing wrong while the host idled
    const sim::EmulatedDriveCounters& c = rig.emulator().status(i).counters;
    EXPECT_EQ(c.emcy_sent, 0u) << "drive " << i;
    EXPECT_EQ(c.deadline_trips, 0u) << "drive " << i;
    EXPECT_EQ(c.heartbeat_losses, 0u) << "drive " << i;
  }

  const std::uint64_t id =
      ex.start(ex.prepare_program(paper(), robot().trajectory.rebase, ex.estop_epoch()));
  for (int k = 0; k < 20000 && !has(LoopEvent::Kind::kFinished) && !has(LoopEvent::Kind::kStopped);
       ++k)
    step();
  ASSERT_TRUE(has(LoopEvent::Kind::kFinished))
      << "latched: " << safety::describe_faults(ex.snapshot().latched);
  EXPECT_FALSE(has(LoopEvent::Kind::kStopped));
  EXPECT_EQ(events.front().id, id);
  step();
  EXPECT_EQ(ex.snapshot().mode, LoopMode::kIdle);
  // Never a gap in the cycle on the wire, never a torque above the limit.
  EXPECT_EQ(longest_sync_gap, static_cast<std::uint64_t>(robot().loop.period_ns));
  EXPECT_LE(max_torque, robot().safety.torque.max + 1e-9);
  EXPECT_GT(max_torque, 1.0);  // it did move
}

}  // namespace
}  // namespace dualv::control
