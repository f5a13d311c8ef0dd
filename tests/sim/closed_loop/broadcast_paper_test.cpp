// Issue 15: the paper program in closed loop over CANopen frames on the in-process rig
// (master -> drive emulator -> plant), once with the per-drive layout and once with the
// broadcast layout, everything else as shipped (config/dualv.yaml, 1 kHz). The broadcast
// layout only changes how the same numbers travel, so the tracking must be the same within
// noise; the wire must be the configured layout and never carry a torque above the limit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "control/loop/executor.hpp"
#include "drivers/canopen_config.hpp"
#include "drivers/canopen_setup.hpp"
#include "firmware_if/firmware_if.hpp"
#include "safety/fault_log.hpp"
#include "sim/in_process_can_rig.hpp"
#include "tests/safety/paper_fixture.hpp"
#include "tests/support/can_rig_time.hpp"

namespace dualv::sim {
namespace {

using dualv::test::RigClock;
using dualv::test::RigWaiter;
using safety::test::paper;
using safety::test::robot;

struct PaperRun {
  bool finished = false;
  std::string why;
  double max_error = 0.0;  // [m] |(x, y) true - desired| while the program runs
  double rms_error = 0.0;
  double max_wire_torque = 0.0;        // [N m] largest target torque in any frame
  int wrong_frames = 0;                // frames of the other layout
  int statusword_frames = 0;           // broadcast: TPDO3s seen
  std::array<bool, 4> enabled_seen{};  // Operation enabled seen in a statusword per drive
};

PaperRun run_paper(fw::BusLayout layout) {
  drivers::CanConfig can = drivers::load_can_config_file(robot().path);
  can.bus_layout = layout;
  InProcessCanRig rig(robot().model, robot().plant, can, 4096);
  RigClock clock(rig);
  RigWaiter waiter(rig);
  auto drives = drivers::boot_actuator_set(rig.master_bus(), clock, waiter, can);
  control::ExecutorConfig ec;
  ec.cycle = {robot().period(), 2.0, robot().safety};
  control::Executor ex(robot().model, robot().control, ec, *drives);

  PaperRun r;
  const bool broadcast = layout == fw::BusLayout::kBroadcast;
  const bool fd = layout == fw::BusLayout::kFd;
  auto watch = [&] {
    fw::CanFrame f;
    while (rig.monitor_bus().receive(f) == drivers::BusStatus::kOk) {
      // CAN FD frames in the fd layout only, and there for the PDOs only: the RPDO, TPDO1 and
      // TPDO2 (60FDh digital inputs); SYNC, NMT, heartbeat, EMCY, SDO stay classic.
      const bool pdo = f.id == fw::kBroadcastRpdoCobId || (f.id >= 0x181 && f.id <= 0x184) ||
                       (f.id >= 0x281 && f.id <= 0x284);
      if (f.fd != (fd && pdo)) ++r.wrong_frames;
      if (fd && f.id == fw::kBroadcastRpdoCobId) {
        const auto c = fw::decode_fd_commands(f, 4);
        if (!c || f.dlc != 16) {
          ++r.wrong_frames;
          continue;
        }
        for (int i = 0; i < 4; ++i)
          r.max_wire_torque = std::max(
              r.max_wire_torque,
              std::abs(fw::per_mille_to_nm(c->command[static_cast<std::size_t>(i)].target_torque,
                                           can.drives[static_cast<std::size_t>(i)].rated_torque)));
      } else if (broadcast && f.id == fw::kBroadcastRpdoCobId) {
        const auto t = fw::decode_broadcast_torques(f);
        if (!t || t->drives != 4) {
          ++r.wrong_frames;
          continue;
        }
        for (int i = 0; i < 4; ++i)
          r.max_wire_torque = std::max(
              r.max_wire_torque,
              std::abs(fw::per_mille_to_nm(t->torque[static_cast<std::size_t>(i)],
                                           can.drives[static_cast<std::size_t>(i)].rated_torque)));
      } else if (f.id >= 0x201 && f.id <= 0x204) {
        if (fd || broadcast != (f.dlc == 2)) ++r.wrong_frames;  // broadcast: controlword alone
        if (!broadcast && f.dlc == 4) {
          const auto c = fw::decode_rpdo1(f);
          r.max_wire_torque = std::max(
              r.max_wire_torque, std::abs(fw::per_mille_to_nm(
                                     c->target_torque, can.drives[f.id - 0x201].rated_torque)));
        }
      } else if (f.id >= 0x181 && f.id <= 0x184) {
        if (f.dlc != (broadcast ? 4 : 6)) ++r.wrong_frames;
        if (!broadcast) {
          const auto fb = fw::decode_tpdo1(f);
          if (fb &&
              fw::decode_statusword(fb->statusword)->state == fw::Cia402State::kOperationEnabled)
            r.enabled_seen[f.id - 0x181] = true;
        }
      } else if (f.id >= 0x381 && f.id <= 0x384) {
        if (!broadcast) ++r.wrong_frames;
        ++r.statusword_frames;
        const auto sw = fw::decode_statusword_tpdo(f);
        if (sw && fw::decode_statusword(*sw)->state == fw::Cia402State::kOperationEnabled)
          r.enabled_seen[f.id - 0x381] = true;
      }
    }
  };
  watch();
  std::int64_t cycle = 0;
  bool done = false, stopped = false;
  double sum_sq = 0.0;
  long samples = 0;
  auto step = [&] {
    control::CycleInfo info;
    info.cycle = cycle++;
    info.period_ns = robot().loop.period_ns;
    ex.step(info);
    const control::CycleRecord& rec = ex.record();
    rig.step(static_cast<std::uint64_t>(robot().loop.period_ns));
    watch();
    if (rec.phase == control::CyclePhase::kRunning) {
      const model::Pose& X = rig.plant().output().X;
      const double e = std::hypot(X[0] - rec.ref.cartesian.X[0], X[1] - rec.ref.cartesian.X[1]);
      r.max_error = std::max(r.max_error, e);
      sum_sq += e * e;
      ++samples;
    }
    control::LoopEvent e;
    while (ex.poll_event(e)) {
      done = done || e.kind == control::LoopEvent::Kind::kFinished;
      stopped = stopped || e.kind == control::LoopEvent::Kind::kStopped;
    }
    ex.collect();
  };
  for (int k = 0; k < 50; ++k) step();
  ex.start(ex.prepare_program(paper(), robot().trajectory.rebase, ex.estop_epoch()));
  for (int k = 0; k < 20000 && !done && !stopped; ++k) step();
  r.finished = done && !stopped;
  r.why = safety::describe_faults(ex.snapshot().latched);
  r.rms_error = samples ? std::sqrt(sum_sq / static_cast<double>(samples)) : 0.0;
  return r;
}

TEST(BroadcastLayoutOnTheRig, PaperProgramTracksAsThePerDriveLayout) {
  const PaperRun per_drive = run_paper(fw::BusLayout::kPerDrive);
  const PaperRun broadcast = run_paper(fw::BusLayout::kBroadcast);
  ASSERT_TRUE(per_drive.finished) << per_drive.why;
  ASSERT_TRUE(broadcast.finished) << broadcast.why;
  // The loop tracks at all (README: 0.43 mm with the shipped configuration) ...
  EXPECT_LT(per_drive.max_error, 1e-3);
  EXPECT_GT(per_drive.rms_error, 0.0);
  // ... and the layout changes the transport, not the control: same within 5 %.
  EXPECT_NEAR(broadcast.max_error, per_drive.max_error, 0.05 * per_drive.max_error);
  EXPECT_NEAR(broadcast.rms_error, per_drive.rms_error, 0.05 * per_drive.rms_error);
  // The wire is the configured layout, no torque above the limit, every drive seen enabled.
  for (const PaperRun* r : {&per_drive, &broadcast}) {
    EXPECT_EQ(r->wrong_frames, 0);
    EXPECT_LE(r->max_wire_torque, robot().safety.torque.max + 1e-9);
    EXPECT_GT(r->max_wire_torque, 1.0);
    for (int i = 0; i < 4; ++i) EXPECT_TRUE(r->enabled_seen[static_cast<std::size_t>(i)]) << i;
  }
  EXPECT_EQ(per_drive.statusword_frames, 0);
  EXPECT_GE(broadcast.statusword_frames, 4 * 3);  // each drive's walk to Operation enabled
  std::printf(
      "paper program on the CAN rig: max |e| %.4f / %.4f mm, RMS %.4f / %.4f mm "
      "(per-drive / broadcast)\n",
      1e3 * per_drive.max_error, 1e3 * broadcast.max_error, 1e3 * per_drive.rms_error,
      1e3 * broadcast.rms_error);
}

// The CAN FD layout (one FD RPDO with every controlword + torque, FD TPDO1s): the transport
// changes, the tracking does not.
TEST(FdLayoutOnTheRig, PaperProgramTracksAsThePerDriveLayout) {
  const PaperRun per_drive = run_paper(fw::BusLayout::kPerDrive);
  const PaperRun fd = run_paper(fw::BusLayout::kFd);
  ASSERT_TRUE(per_drive.finished) << per_drive.why;
  ASSERT_TRUE(fd.finished) << fd.why;
  EXPECT_LT(fd.max_error, 1e-3);
  EXPECT_NEAR(fd.max_error, per_drive.max_error, 0.05 * per_drive.max_error);
  EXPECT_NEAR(fd.rms_error, per_drive.rms_error, 0.05 * per_drive.rms_error);
  EXPECT_EQ(fd.wrong_frames, 0);
  EXPECT_LE(fd.max_wire_torque, robot().safety.torque.max + 1e-9);
  EXPECT_GT(fd.max_wire_torque, 1.0);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(fd.enabled_seen[static_cast<std::size_t>(i)]) << i;
  EXPECT_EQ(fd.statusword_frames, 0);
  std::printf(
      "paper program on the CAN rig: max |e| %.4f / %.4f mm, RMS %.4f / %.4f mm "
      "(per-drive / fd)\n",
      1e3 * per_drive.max_error, 1e3 * fd.max_error, 1e3 * per_drive.rms_error, 1e3 * fd.rms_error);
}

}  // namespace
}  // namespace dualv::sim
