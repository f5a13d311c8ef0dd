// The safety scenarios over CAN frames: the control cycle (with the safety filter) drives
// the CANopen actuator set on the in-process bus, the drive emulator answers, and a monitor
// endpoint captures every frame. Torque limits are checked on the captured RPDOs (decoded
// with firmware_if), not on internal variables. Simulated time, deterministic.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "control/loop/control_cycle.hpp"
#include "control/trajectory/program.hpp"
#include "drivers/canopen_config.hpp"
#include "drivers/canopen_setup.hpp"
#include "firmware_if/firmware_if.hpp"
#include "paper_fixture.hpp"
#include "safety/fault_injector.hpp"
#include "sim/in_process_can_rig.hpp"
#include "tests/support/can_rig_time.hpp"

namespace dualv::safety::test {
namespace {

using drivers::DriveRequest;

using dualv::test::RigClock;
using dualv::test::RigWaiter;

struct WireStats {
  double max_torque = 0.0;  // [N m] largest target torque in any captured RPDO
  int rpdos = 0;
  std::array<std::int16_t, 4> last_per_mille{};
  std::array<std::uint16_t, 4> last_controlword{};
};

struct CanRig {
  CanRig()
      : can(drivers::load_can_config_file(robot().path)),
        rig(robot().model, robot().plant, can),
        clock(rig),
        waiter(rig),
        drives(drivers::boot_actuator_set(rig.master_bus(), clock, waiter, can)),
        io(*drives),
        cycle(robot().model, robot().control, {robot().period(), 2.0, robot().safety}) {
    drain_wire();
    stats = {};
    cycle.start(io, paper(), robot().trajectory.rebase);
  }
  void drain_wire() {
    fw::CanFrame f;
    while (rig.monitor_bus().receive(f) == drivers::BusStatus::kOk) {
      if (f.id == 0x200 && can.bus_layout != fw::BusLayout::kPerDrive) {
        const auto b = fw::decode_broadcast_torques(f);
        if (!b.ok()) continue;
        for (int i = 0; i < 4; ++i) observe(i, b->torque[i], stats.last_controlword[i]);
        continue;
      }
      if (f.id < 0x201 || f.id > 0x204) continue;
      const auto c = fw::decode_rpdo1(f);
      if (!c.ok()) continue;
      const int i = static_cast<int>(f.id - 0x201);
      stats.last_controlword[i] = c->controlword;
      if (f.dlc >= 4) observe(i, c->target_torque, c->controlword);
    }
  }
  void observe(int i, std::int16_t per_mille, std::uint16_t) {
    const double nm = fw::per_mille_to_nm(per_mille, can.drives[i].rated_torque);
    stats.max_torque = std::max(stats.max_torque, std::abs(nm));
    stats.last_per_mille[i] = per_mille;
    ++stats.rpdos;
  }
  control::CycleStatus step() {
    const control::CycleStatus s = cycle.step(io, rec);
    rig.step(static_cast<std::uint64_t>(robot().loop.period_ns));
    drain_wire();
    FaultEvent e;
    while (cycle.safety().log().try_pop(e)) events.push_back(e);
    return s;
  }
  void run_until(double t) {
    for (int k = 0; k < 20000 && !(rec.phase == control::CyclePhase::kRunning && rec.t >= t); ++k)
      ASSERT_EQ(step(), control::CycleStatus::kOk)
          << "cycle " << rec.cycle << ": " << (events.empty() ? "" : describe(events.back()));
    ASSERT_EQ(rec.phase, control::CyclePhase::kRunning);
  }
  const FaultEvent* first_stop() const {
    for (const auto& e : events)
      if (e.kind == EventKind::kFault && e.reaction != Reaction::kWarn) return &e;
    return nullptr;
  }
  bool wire_torque_off() const {
    for (int i = 0; i < 4; ++i)
      if (stats.last_per_mille[i] != 0) return false;
    return true;
  }

  drivers::CanConfig can;
  sim::InProcessCanRig rig;
  RigClock clock;
  RigWaiter waiter;
  std::unique_ptr<drivers::CanopenActuatorSet> drives;
  FaultInjector io;
  control::ControlCycle cycle;
  control::CycleRecord rec;
  std::vector<FaultEvent> events;
  WireStats stats;
};

double wire_limit() {
  return robot().safety.torque.max + 0.5 * 1e-3 * 50.0;  // + half a per mille (quantisation)
}

TEST(SafetyCan, PaperProgramRunsOverCanWithoutSafetyEvents) {
  CanRig r;
  for (int k = 0; k < 4000; ++k) ASSERT_EQ(r.step(), control::CycleStatus::kOk) << k;
  EXPECT_EQ(r.first_stop(), nullptr);
  EXPECT_GT(r.stats.rpdos, 4 * 3900);
  EXPECT_GT(r.stats.max_torque, 1.0);  // it did move
  EXPECT_LE(r.stats.max_torque, wire_limit());
}

TEST(SafetyCan, EstopIsSs1ThenTorqueOffOnTheWire) {
  CanRig r;
  r.run_until(2.0);
  const std::int64_t injected = r.rec.cycle + 1;
  r.cycle.safety().request_stop(StopSource::kLcm);
  int k = 0;
  for (; k < 2000 && r.rec.command.request != DriveRequest::kDisable; ++k) r.step();
  const FaultEvent* e = r.first_stop();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->fault, Fault::kEstopLcm);
  EXPECT_LE(e->cycle - injected, 2);
  EXPECT_LE(k, r.cycle.safety().limits().ss1_max);
  for (int j = 0; j < 5; ++j) r.step();
  EXPECT_TRUE(r.wire_torque_off());
  EXPECT_LE(r.stats.max_torque, wire_limit());
  for (int i = 0; i < 4; ++i)
    EXPECT_NE(r.rig.emulator().status(i).state, fw::Cia402State::kOperationEnabled) << i;
}

TEST(SafetyCan, DriveFaultEmcyIsStoWithinTwoCycles) {
  CanRig r;
  r.run_until(1.5);
  const std::int64_t injected = r.rec.cycle + 1;
  r.rig.emulator().inject_fault(2, 0x2310);
  for (int k = 0; k < 5; ++k) r.step();
  const FaultEvent* e = r.first_stop();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->reaction, Reaction::kSto);
  EXPECT_LE(e->cycle - injected, 2) << to_string(e->fault);
  EXPECT_TRUE(r.wire_torque_off());
  EXPECT_LE(r.stats.max_torque, wire_limit());
}

TEST(SafetyCan, SilentDriveStopsAllAtTheStaleTimeout) {
  CanRig r;
  r.run_until(1.5);
  const std::int64_t injected = r.rec.cycle + 1;
  r.rig.emulator().set_silent(1, true);
  for (int k = 0; k < 10; ++k) r.step();
  const FaultEvent* e = r.first_stop();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->reaction, Reaction::kSto);
  // Feedback is one cycle old on CAN: the k-th stale cycle comes one cycle later.
  EXPECT_LE(e->cycle - injected, robot().safety.watchdogs.stale_feedback_cycles + 1)
      << to_string(e->fault);
  EXPECT_TRUE(r.wire_torque_off());
}

TEST(SafetyCan, EncoderJumpIsSto) {
  CanRig r;
  r.run_until(1.5);
  const std::int64_t injected = r.rec.cycle + 1;
  r.rig.emulator().inject_encoder_offset(3, 1 << 15);  // 0.2 rad at 2^20 counts/rev
  for (int k = 0; k < 5; ++k) r.step();
  const FaultEvent* e = r.first_stop();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->fault, Fault::kEncoderJump);
  EXPECT_LE(e->cycle - injected, 2);
  EXPECT_TRUE(r.wire_torque_off());
}

TEST(SafetyCan, DroppedTpdosAreStaleFeedback) {
  CanRig r;
  r.run_until(1.5);
  r.rig.emulator().drop_tpdos(0, sim::DriveEmulator::kForever);
  for (int k = 0; k < 10; ++k) r.step();
  const FaultEvent* e = r.first_stop();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->fault, Fault::kStaleFeedback);
  EXPECT_TRUE(r.wire_torque_off());
}

void ten_times(void* ctx, std::int64_t cycle, drivers::ActuatorCommand& c) noexcept {
  if (cycle >= *static_cast<std::int64_t*>(ctx))
    for (int i = 0; i < c.n; ++i) c.torque[i] = (i % 2 ? -1.0 : 1.0) * 600.0;
}

TEST(SafetyCan, TenTimesTheLimitNeverReachesTheWire) {
  CanRig r;
  r.run_until(2.0);
  std::int64_t from = r.rec.cycle + 1;
  r.cycle.set_command_hook(ten_times, &from);
  for (int k = 0; k < 1000; ++k) r.step();
  const FaultEvent* e = r.first_stop();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->fault, Fault::kTorqueLimit);
  EXPECT_EQ(e->cycle, from);
  EXPECT_LE(r.stats.max_torque, wire_limit());
  EXPECT_TRUE(r.wire_torque_off());
}

TEST(SafetyCan, HardwiredEstopButtonStopsEverything) {
  CanRig r;
  r.run_until(1.5);
  const std::int64_t injected = r.rec.cycle + 1;
  r.rig.emulator().press_estop(true);
  for (int k = 0; k < 5; ++k) r.step();
  const FaultEvent* e = r.first_stop();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->reaction, Reaction::kSto);
  EXPECT_LE(e->cycle - injected, 2) << to_string(e->fault);
  EXPECT_TRUE(r.wire_torque_off());
}

bool all_drives_torque_free(CanRig& r) {
  for (int i = 0; i < 4; ++i) {
    const auto st = r.rig.emulator().status(i);
    if (st.state == fw::Cia402State::kOperationEnabled || st.torque_nm != 0.0) return false;
  }
  return true;
}

TEST(SafetyCan, BusOffIsStoAndTheDrivesStopOnTheirOwn) {
  CanRig r;
  r.run_until(1.5);
  const std::int64_t injected = r.rec.cycle + 1;
  r.rig.master_bus().force_bus_off(true);
  r.step();
  const FaultEvent* e = r.first_stop();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->reaction, Reaction::kSto);
  EXPECT_EQ(e->cycle, injected);
  bool bus_error = false;  // logged in the same cycle (with "drive lost": nothing is heard)
  for (const auto& ev : r.events)
    bus_error = bus_error || (ev.fault == Fault::kBusError && ev.cycle == injected);
  EXPECT_TRUE(bus_error);
  // The master can send nothing: the drives' RPDO watchdog (3 SYNCs without a target
  // torque; here the SYNCs stop too, so the emulator's free run and its deadline monitor)
  // must take the torque off by themselves.
  for (int k = 0; k < 200 && !all_drives_torque_free(r); ++k) r.step();
  EXPECT_TRUE(all_drives_torque_free(r));
  EXPECT_LE(r.stats.max_torque, wire_limit());
}

TEST(SafetyCan, HostDiesAndTheDrivesStopOnTheirOwn) {
  CanRig r;
  r.run_until(1.5);
  // The process is gone: no SYNC, no RPDO, no heartbeat. Only the bus and the drives run.
  int k = 0;
  for (; k < 1000 && !all_drives_torque_free(r); ++k)
    r.rig.step(static_cast<std::uint64_t>(robot().loop.period_ns));
  EXPECT_TRUE(all_drives_torque_free(r));
  // Within the master heartbeat consumer time (1016h) at the latest.
  EXPECT_LE(static_cast<double>(k) * robot().period(),
            static_cast<double>(r.can.master_heartbeat_timeout_ns) * 1e-9 + 0.06)
      << k;
}

TEST(SafetyCan, TwoCyclesOfDroppedFeedbackAreToleratedMoreAreSto) {
  CanRig r;
  r.run_until(1.5);
  const int stale = robot().safety.watchdogs.stale_feedback_cycles;
  r.rig.hub().endpoint(sim::InProcessCanRig::kEmulatorEndpoint).drop_next(4 * (stale - 1));
  for (int k = 0; k < 50; ++k) r.step();
  EXPECT_EQ(r.first_stop(), nullptr) << describe(*r.first_stop());
  r.rig.hub().endpoint(sim::InProcessCanRig::kEmulatorEndpoint).drop_next(4 * (stale + 3));
  for (int k = 0; k < stale + 4; ++k) r.step();
  const FaultEvent* e = r.first_stop();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->reaction, Reaction::kSto) << describe(*e);
  EXPECT_TRUE(r.wire_torque_off());
}

TEST(SafetyCan, CorruptedFeedbackIsStoWithinTwoCycles) {
  CanRig r;
  r.run_until(1.5);
  const std::int64_t injected = r.rec.cycle + 1;
  r.rig.hub().endpoint(sim::InProcessCanRig::kEmulatorEndpoint).corrupt_next(4, 0x5A);
  for (int k = 0; k < 5; ++k) r.step();
  const FaultEvent* e = r.first_stop();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->reaction, Reaction::kSto) << describe(*e);
  EXPECT_LE(e->cycle - injected, 2) << describe(*e);
  EXPECT_LE(r.stats.max_torque, wire_limit());
  EXPECT_TRUE(r.wire_torque_off());
}

TEST(SafetyCan, DelayedFeedbackNeverPutsTorqueAboveTheLimit) {
  CanRig r;
  r.run_until(1.5);
  r.rig.hub().endpoint(sim::InProcessCanRig::kEmulatorEndpoint).delay_next(4, 8);
  for (int k = 0; k < 100; ++k) r.step();
  EXPECT_LE(r.stats.max_torque, wire_limit());
  if (const FaultEvent* e = r.first_stop()) {
    std::printf("  delayed TPDOs: %s\n", describe(*e).c_str());
    EXPECT_TRUE(r.wire_torque_off());
  }
}

}  // namespace
}  // namespace dualv::safety::test
