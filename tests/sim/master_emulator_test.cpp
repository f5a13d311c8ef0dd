// The real CANopen master (drivers/canopen_setup.hpp boot + CanopenActuatorSet) against
// the drive emulator, in-process over CAN frames (InProcessCanRig), in simulated time:
// the whole wire contract exercised from both ends without a fake on either side.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "drivers/canopen_actuator_set.hpp"
#include "drivers/canopen_config.hpp"
#include "drivers/canopen_setup.hpp"
#include "sim/in_process_can_rig.hpp"
#include "tests/sim/sim_fixture.hpp"
#include "tests/support/can_rig_time.hpp"

namespace dualv::sim {
namespace {

using dualv::test::RigClock;
using dualv::test::RigWaiter;

std::vector<fw::CanFrame> drain_all(drivers::InProcessBus& bus) {
  std::vector<fw::CanFrame> out;
  fw::CanFrame f;
  while (bus.receive(f) == drivers::BusStatus::kOk) out.push_back(f);
  return out;
}

class MasterEmulator : public ::testing::Test {
 protected:
  MasterEmulator()
      : can(drivers::load_can_config_file(test::config_file())),
        rig(test::dual_v(), load_plant_config_file(test::config_file()), can),
        clock(rig),
        waiter(rig) {}
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
    return r;
  }

  drivers::CanConfig can;
  InProcessCanRig rig;
  RigClock clock;
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

// Issue 12 point 5, driver side: a drive fault whose cause remains, then goes. The host
// sees the EMCY and Fault; kFaultReset makes a rising edge of controlword bit 7 (CiA 402
// transition 15); the emulator refuses it while the cause remains; once it is gone the
// drive reaches Switch on disabled, the EMCY 0000h clears the host's EMCY, and nothing
// re-enables by itself.
TEST_F(MasterEmulator, DriveFaultClearsOnTheHostAfterResetOnceTheCauseIsGone) {
  boot();
  for (int k = 0; k < 20; ++k) cycle(drivers::DriveRequest::kEnable);
  ASSERT_EQ(fb.drive[1].state, drivers::DriveState::kEnabled);
  rig.emulator().hold_fault(1, fw::emcy::kDeviceOverTemperature);
  for (int k = 0; k < 3; ++k) cycle(drivers::DriveRequest::kHold);
  EXPECT_EQ(fb.drive[1].state, drivers::DriveState::kFault);
  EXPECT_EQ(fb.drive[1].last_emcy, fw::emcy::kDeviceOverTemperature);
  EXPECT_EQ(actuators->health(1).health, drivers::DriveHealth::kError);

  // Reset while the cause remains: refused by the drive, the host stays in Fault.
  (void)drain_all(rig.monitor_bus());
  for (int k = 0; k < 10; ++k) cycle(drivers::DriveRequest::kFaultReset);
  std::vector<std::uint16_t> cw2;  // controlwords sent to node 2 (RPDO1 202h)
  for (const fw::CanFrame& f : drain_all(rig.monitor_bus()))
    if (f.id == 0x202) cw2.push_back(fw::get_u16_le(f.data.data()));
  ASSERT_GE(cw2.size(), 2u);
  EXPECT_EQ(cw2[0] & fw::cw::kFaultReset, 0);  // bit 7 low first ...
  EXPECT_NE(cw2[1] & fw::cw::kFaultReset, 0);  // ... then high: the rising edge
  EXPECT_GE(rig.emulator().status(1).counters.fault_resets_refused, 1u);
  EXPECT_EQ(fb.drive[1].state, drivers::DriveState::kFault);
  EXPECT_EQ(fb.drive[1].last_emcy, fw::emcy::kDeviceOverTemperature);

  // The cause goes; a new reset request (a new edge) works.
  rig.emulator().release_fault(1);
  cycle(drivers::DriveRequest::kHold);
  for (int k = 0; k < 10; ++k) cycle(drivers::DriveRequest::kFaultReset);
  EXPECT_EQ(rig.emulator().status(1).state, fw::Cia402State::kSwitchOnDisabled);
  EXPECT_EQ(rig.emulator().status(1).last_transition, 15);
  EXPECT_EQ(fb.drive[1].state, drivers::DriveState::kDisabled);
  EXPECT_EQ(fb.drive[1].last_emcy, 0);  // EMCY 0000h received
  const drivers::DriveHealthReport h = actuators->health(1);
  EXPECT_FALSE(h.emcy_active);
  EXPECT_NE(h.health, drivers::DriveHealth::kError) << h.reason;

  // Nothing re-enables by itself, however long the reset or hold is given.
  for (int k = 0; k < 100; ++k)
    cycle(k % 2 ? drivers::DriveRequest::kHold : drivers::DriveRequest::kFaultReset);
  EXPECT_EQ(rig.emulator().status(1).state, fw::Cia402State::kSwitchOnDisabled);
  EXPECT_EQ(rig.emulator().status(1).torque_nm, 0.0);
  // A new enable does.
  cycle(drivers::DriveRequest::kHold);
  for (int k = 0; k < 20; ++k) cycle(drivers::DriveRequest::kEnable);
  EXPECT_EQ(fb.drive[1].state, drivers::DriveState::kEnabled);
}

// Issue 13 defect 6: shutdown leaves the drives disabled and NMT pre-operational, from the
// frames on the wire.
TEST_F(MasterEmulator, ShutDownDisablesThenEntersPreOperational) {
  boot();
  for (int k = 0; k < 20; ++k) cycle(drivers::DriveRequest::kEnable);
  ASSERT_EQ(rig.emulator().status(0).state, fw::Cia402State::kOperationEnabled);
  (void)drain_all(rig.monitor_bus());
  std::vector<std::string> log;
  EXPECT_TRUE(actuators->shut_down(waiter, [&](const std::string& l) { log.push_back(l); }));
  rig.step(can.sync_period_ns);  // the emulator handles the NMT frames
  const std::vector<fw::CanFrame> wire = drain_all(rig.monitor_bus());
  // Every RPDO after the call: disable voltage, torque 0; each cycle ends in SYNC.
  int rpdos = 0, syncs = 0;
  std::size_t first_nmt = wire.size(), last_sync = 0;
  for (std::size_t k = 0; k < wire.size(); ++k) {
    const fw::CanFrame& f = wire[k];
    if (f.id >= 0x201 && f.id <= 0x204) {
      ++rpdos;
      // Disable voltage: bit 1 (enable voltage) low, CiA 402-2 table 29 (xxxx xx0x).
      EXPECT_EQ(fw::get_u16_le(f.data.data()) & fw::cw::kEnableVoltage, 0) << "controlword";
      EXPECT_EQ(fw::get_u16_le(f.data.data() + 2), 0) << "torque";
    }
    if (f.id == 0x080) {
      ++syncs;
      last_sync = k;
    }
    if (f.id == 0x000 && first_nmt == wire.size()) first_nmt = k;
  }
  EXPECT_EQ(syncs, 5);
  EXPECT_EQ(rpdos, 20);
  // Then NMT enter pre-operational (80h) to each node, after the last SYNC.
  ASSERT_LT(first_nmt, wire.size());
  EXPECT_GT(first_nmt, last_sync);
  std::vector<std::string> nmt;
  for (const fw::CanFrame& f : wire)
    if (f.id == 0x000) nmt.push_back(fmt::format("{:02X}{:02X}", f.data[0], f.data[1]));
  EXPECT_EQ(nmt, (std::vector<std::string>{"8001", "8002", "8003", "8004"}));
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(rig.emulator().status(i).state, fw::Cia402State::kSwitchOnDisabled) << i;
    EXPECT_EQ(rig.emulator().status(i).nmt, EmulatedNmt::kPreOperational) << i;
  }
  ASSERT_EQ(log.size(), 2u);
  EXPECT_NE(log[0].find("disable voltage"), std::string::npos) << log[0];
  EXPECT_NE(log[0].find("node 4: Switch on disabled"), std::string::npos) << log[0];
  EXPECT_NE(log[1].find("NMT enter pre-operational sent to nodes 1, 2, 3, 4"), std::string::npos)
      << log[1];
}

TEST_F(MasterEmulator, ShutDownAsConfigured) {
  can.on_exit = drivers::OnExit::kStopped;
  boot();
  for (int k = 0; k < 20; ++k) cycle(drivers::DriveRequest::kEnable);
  std::vector<std::string> log;
  actuators->shut_down(waiter, [&](const std::string& l) { log.push_back(l); });
  rig.step(can.sync_period_ns);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(rig.emulator().status(i).nmt, EmulatedNmt::kStopped);

  can.on_exit = drivers::OnExit::kOperationalDisabled;
  actuators.reset();
  boot();
  for (int k = 0; k < 20; ++k) cycle(drivers::DriveRequest::kEnable);
  log.clear();
  actuators->shut_down(waiter, [&](const std::string& l) { log.push_back(l); });
  rig.step(can.sync_period_ns);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(rig.emulator().status(i).nmt, EmulatedNmt::kOperational);
    EXPECT_EQ(rig.emulator().status(i).state, fw::Cia402State::kSwitchOnDisabled);
  }
  ASSERT_EQ(log.size(), 2u);
  EXPECT_NE(log[1].find("operational_disabled"), std::string::npos);
}

// Issue 13: a drive that answers uploads without size and lacks 60C2h boots with the shipped
// configuration and closes the loop.
TEST_F(MasterEmulator, ForeignDriveBootsAndRuns) {
  DriveEmulatorConfig foreign = emulator_config_from(can);
  foreign.upload_without_size = true;
  foreign.absent_objects = {0x60C2};
  InProcessCanRig frig(test::dual_v(), load_plant_config_file(test::config_file()), foreign);
  RigClock fclock(frig);
  RigWaiter fwaiter(frig);
  std::vector<std::string> log;
  auto set = drivers::boot_actuator_set(frig.master_bus(), fclock, fwaiter, can,
                                        [&](const std::string& l) { log.push_back(l); });
  int skipped = 0;
  for (const std::string& l : log)
    skipped += l.find("interpolation_period skipped") != std::string::npos;
  EXPECT_EQ(skipped, 4);
  drivers::ActuatorFeedback f;
  drivers::ActuatorCommand cmd;
  cmd.n = 4;
  for (int k = 0; k < 30; ++k) {
    set->read(f);
    cmd.request = drivers::DriveRequest::kEnable;
    set->write(cmd);
    frig.step(can.sync_period_ns);
  }
  for (int i = 0; i < 4; ++i)
    EXPECT_EQ(f.drive[static_cast<std::size_t>(i)].state, drivers::DriveState::kEnabled) << i;
}

// A rig for one bus layout (issue 15): the shipped config with `can.bus_layout` set, the
// emulator as that config (or `emu`) describes its drives, a monitor that sees every frame.
struct LayoutRig {
  using Objects = std::vector<std::pair<std::pair<std::uint16_t, std::uint8_t>, std::uint32_t>>;

  explicit LayoutRig(fw::BusLayout layout)
      : LayoutRig(layout, emulator_config_from(with_layout(layout))) {}
  LayoutRig(fw::BusLayout layout, const DriveEmulatorConfig& emu)
      : c(with_layout(layout)),
        r(test::dual_v(), load_plant_config_file(test::config_file()), emu, 4096),
        clk(r),
        w(r) {}
  static drivers::CanConfig with_layout(fw::BusLayout layout) {
    drivers::CanConfig c = drivers::load_can_config_file(test::config_file());
    c.bus_layout = layout;
    return c;
  }
  std::unique_ptr<drivers::CanopenActuatorSet> boot() {
    return drivers::boot_actuator_set(r.master_bus(), clk, w, c);
  }
  // The object dictionary of the drive in `slot` holds `want` (read back from the emulator).
  void expect_objects(int slot, const Objects& want) {
    std::uint32_t v = 0;
    for (const auto& [key, value] : want) {
      ASSERT_TRUE(r.emulator().read_object(slot, key.first, key.second, v));
      EXPECT_EQ(v, value) << std::hex << key.first << " sub " << int(key.second);
    }
  }
  // One cycle of `set` (read, write `cmd`), one SYNC period of the rig: the frames it carried.
  std::vector<fw::CanFrame> cycle(drivers::CanopenActuatorSet& set, drivers::ActuatorFeedback& f,
                                  const drivers::ActuatorCommand& cmd) {
    set.read(f);
    set.write(cmd);
    return idle();
  }
  // One SYNC period of the rig with the host silent.
  std::vector<fw::CanFrame> idle() {
    r.step(c.sync_period_ns);
    return drain_all(r.monitor_bus());
  }
  // Boot must fail; the error's text.
  std::string boot_error() {
    try {
      (void)boot();
    } catch (const std::exception& ex) {
      return ex.what();
    }
    ADD_FAILURE() << "booted";
    return {};
  }

  drivers::CanConfig c;
  InProcessCanRig r;
  RigClock clk;
  RigWaiter w;
};

// Issue 15: the broadcast layout booted by the real master into the emulator, checked on
// the wire (a monitor sees every frame) against the frames the layout defines.
TEST(MasterEmulatorBroadcast, BootsRunsAndTheWireIsTheLayout) {
  LayoutRig rig(fw::BusLayout::kBroadcast);
  const drivers::CanConfig& c = rig.c;
  InProcessCanRig& r = rig.r;
  auto set = rig.boot();
  // The mappings read back from the drives' dictionaries: node 3 (slot 2) maps dummy,
  // dummy, 6071h, dummy in RPDO2 (1601h) on 200h; TPDO1 = 6064h; TPDO3 = 6041h.
  rig.expect_objects(2, {{{0x1401, 1}, 0x00000200},
                         {{0x1601, 0}, 4},
                         {{0x1601, 1}, 0x00030010},
                         {{0x1601, 2}, 0x00030010},
                         {{0x1601, 3}, 0x60710010},
                         {{0x1601, 4}, 0x00030010},
                         {{0x1A00, 0}, 1},
                         {{0x1A00, 1}, 0x60640020},
                         {{0x1802, 1}, 0x40000383},
                         {{0x1802, 2}, 0xFF},
                         {{0x1802, 3}, 100},
                         {{0x1A02, 1}, 0x60410010}});
  (void)drain_all(r.monitor_bus());
  drivers::ActuatorFeedback f;
  drivers::ActuatorCommand cmd;
  cmd.n = 4;
  std::array<std::uint64_t, 4> last_sw{};
  std::array<int, 4> statuswords{};
  std::uint64_t min_sw_gap = ~0ull;
  int torque_frames = 0, positions = 0, syncs = 0;
  for (int k = 0; k < 600; ++k) {
    cmd.request = k < 100 ? drivers::DriveRequest::kEnable : drivers::DriveRequest::kHold;
    cmd.torque = {0.5, -0.5, 0.25, -0.25};
    for (const fw::CanFrame& fr : rig.cycle(*set, f, cmd)) {
      syncs += fr.id == 0x080;
      if (fr.id == 0x200) {
        ++torque_frames;
        EXPECT_EQ(fr.dlc, 8);
      }
      if (fr.id >= 0x181 && fr.id <= 0x184) {
        ++positions;
        EXPECT_EQ(fr.dlc, 4);
      }
      EXPECT_FALSE(fr.id >= 0x201 && fr.id <= 0x204 && fr.dlc != 2) << "per-drive RPDO on the wire";
      if (fr.id >= 0x381 && fr.id <= 0x384) {
        const std::size_t i = fr.id - 0x381;
        EXPECT_EQ(fr.dlc, 2);
        if (statuswords[i]++ > 0) min_sw_gap = std::min(min_sw_gap, fr.timestamp_ns - last_sw[i]);
        last_sw[i] = fr.timestamp_ns;
      }
    }
  }
  EXPECT_EQ(syncs, 600);
  EXPECT_EQ(torque_frames, 600);
  EXPECT_EQ(positions, 4 * 600);
  // Each drive's statusword: its changes on the way to Operation enabled, then the event
  // timer (0.1 s): never two within the inhibit time (10 ms).
  for (int i = 0; i < 4; ++i) EXPECT_GE(statuswords[static_cast<std::size_t>(i)], 5) << i;
  EXPECT_GE(min_sw_gap, c.statusword_inhibit_ns);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(r.emulator().status(i).state, fw::Cia402State::kOperationEnabled) << i;
    EXPECT_EQ(f.drive[static_cast<std::size_t>(i)].state, drivers::DriveState::kEnabled) << i;
    EXPECT_TRUE(f.drive[static_cast<std::size_t>(i)].fresh) << i;
    EXPECT_EQ(r.emulator().status(i).counters.deadline_trips, 0u) << i;
    EXPECT_EQ(r.emulator().status(i).counters.watchdog_trips, 0u) << i;
  }
  EXPECT_EQ(r.emulator().status(1).target_torque, -10);  // -0.5 N m of 50 N m rated

  // The host's stale-feedback check is on the position TPDO1: drive 2 stops sending TPDOs,
  // and the very next read() finds it not fresh (its statusword is still within its bound).
  r.emulator().drop_tpdos(1, DriveEmulator::kForever);
  for (int k = 0; k < 2; ++k) (void)rig.cycle(*set, f, cmd);
  set->read(f);
  EXPECT_FALSE(f.drive[1].fresh);
  EXPECT_TRUE(f.drive[0].fresh);
  // The drives' RPDO deadline is the event timer of the broadcast RPDO (1401h sub5 =
  // can.rpdo_deadline, 10 ms): the host goes silent, every drive trips it once.
  for (int k = 0; k < 15; ++k) (void)rig.idle();
  for (int i = 0; i < 4; ++i) EXPECT_EQ(r.emulator().status(i).counters.deadline_trips, 1u) << i;
}

TEST(MasterEmulatorBroadcast, DriveWithoutDummyMappingRefusedByName) {
  DriveEmulatorConfig e = emulator_config_from(LayoutRig::with_layout(fw::BusLayout::kBroadcast));
  e.refuse_dummy_mapping = true;
  LayoutRig rig(fw::BusLayout::kBroadcast, e);
  const std::string m = rig.boot_error();
  // Node 1 (slot 0) maps 6071h at sub1, its first dummy at sub2.
  EXPECT_NE(m.find("node 1 (can.drives[0]) refuses the CiA 301 dummy mapping entry 0003h"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("1601h sub2"), std::string::npos) << m;
  EXPECT_NE(m.find("use per_drive"), std::string::npos) << m;
  for (int i = 0; i < 4; ++i) EXPECT_NE(rig.r.emulator().status(i).nmt, EmulatedNmt::kOperational);
}

// Issue 15: the CAN FD layout booted by the real master into CAN FD drives, the mappings read
// back from the drives and every frame on the wire checked against the layout by hand.
TEST(MasterEmulatorFd, BootsRunsAndTheWireIsTheLayout) {
  LayoutRig rig(fw::BusLayout::kFd);
  InProcessCanRig& r = rig.r;
  auto set = rig.boot();
  // Node 3 (slot 2): RPDO2 (1401h/1601h) on 200h maps dummy u16 (0006h), dummy i16 (0003h)
  // for slots 0 and 1, its own 6040h + 6071h, then dummies for slot 3; RPDO1 not valid
  // (bit 31); TPDO1 = 6041h + 6064h every SYNC.
  rig.expect_objects(2, {{{0x1400, 1}, 0x80000203},
                         {{0x1401, 1}, 0x00000200},
                         {{0x1401, 2}, 1},
                         {{0x1601, 0}, 8},
                         {{0x1601, 1}, 0x00060010},
                         {{0x1601, 2}, 0x00030010},
                         {{0x1601, 3}, 0x00060010},
                         {{0x1601, 4}, 0x00030010},
                         {{0x1601, 5}, 0x60400010},
                         {{0x1601, 6}, 0x60710010},
                         {{0x1601, 7}, 0x00060010},
                         {{0x1601, 8}, 0x00030010},
                         {{0x1A00, 0}, 2},
                         {{0x1A00, 1}, 0x60410010},
                         {{0x1A00, 2}, 0x60640020},
                         {{0x1800, 2}, 1}});
  (void)drain_all(r.monitor_bus());
  drivers::ActuatorFeedback f;
  drivers::ActuatorCommand cmd;
  cmd.n = 4;
  int fd_rpdos = 0, tpdos = 0, syncs = 0, others = 0;
  fw::CanFrame last_rpdo;
  cmd.request = drivers::DriveRequest::kEnable;
  cmd.torque = {0.5, -0.5, 0.25, -0.25};
  for (int k = 0; k < 300; ++k) {
    for (const fw::CanFrame& fr : rig.cycle(*set, f, cmd)) {
      if (fr.id == 0x080) {
        ++syncs;
        EXPECT_FALSE(fr.fd);  // SYNC stays classic
      } else if (fr.id == 0x200) {
        ++fd_rpdos;
        EXPECT_TRUE(fr.fd);
        EXPECT_TRUE(fr.brs);
        EXPECT_EQ(fr.dlc, 16);
        last_rpdo = fr;
      } else if (fr.id >= 0x181 && fr.id <= 0x184) {
        ++tpdos;
        EXPECT_TRUE(fr.fd);
        EXPECT_TRUE(fr.brs);
        EXPECT_EQ(fr.dlc, 6);
      } else if ((fr.id >= 0x201 && fr.id <= 0x204) || (fr.id >= 0x381 && fr.id <= 0x384)) {
        ++others;  // no per-drive RPDO, no statusword TPDO3
      }
    }
  }
  EXPECT_EQ(syncs, 300);
  EXPECT_EQ(fd_rpdos, 300);
  EXPECT_EQ(tpdos, 4 * 300);
  EXPECT_EQ(others, 0);
  // The last RPDO by hand: Operation enabled (controlword 000Fh) and 0.5, -0.5, 0.25, -0.25 N m
  // of 50 N m rated = 10, -10, 5, -5 per mille, little endian, 4 bytes per drive.
  const std::array<std::uint8_t, 16> bytes{0x0F, 0, 10, 0, 0x0F, 0, 0xF6, 0xFF,
                                           0x0F, 0, 5,  0, 0x0F, 0, 0xFB, 0xFF};
  for (std::size_t b = 0; b < bytes.size(); ++b) EXPECT_EQ(last_rpdo.data[b], bytes[b]) << b;
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(r.emulator().status(i).state, fw::Cia402State::kOperationEnabled) << i;
    EXPECT_EQ(f.drive[static_cast<std::size_t>(i)].state, drivers::DriveState::kEnabled) << i;
    EXPECT_TRUE(f.drive[static_cast<std::size_t>(i)].fresh) << i;
    EXPECT_EQ(r.emulator().status(i).counters.deadline_trips, 0u) << i;
  }
  EXPECT_EQ(r.emulator().status(1).target_torque, -10);
  EXPECT_EQ(r.emulator().status(3).target_torque, -5);
}

TEST(MasterEmulatorFd, ClassicDriveRefusedByName) {
  DriveEmulatorConfig e = emulator_config_from(LayoutRig::with_layout(fw::BusLayout::kFd));
  ASSERT_TRUE(e.fd);
  e.fd = false;  // dualv sim --no-fd: PDOs end at 8 bytes
  LayoutRig rig(fw::BusLayout::kFd, e);
  const std::string m = rig.boot_error();
  EXPECT_NE(m.find("node 1 (can.drives[0]) refuses the 16-byte CAN FD RPDO mapping"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("06040042h"), std::string::npos) << m;  // mapping exceeds the PDO length
  EXPECT_NE(m.find("use per_drive or broadcast"), std::string::npos) << m;
  for (int i = 0; i < 4; ++i) EXPECT_NE(rig.r.emulator().status(i).nmt, EmulatedNmt::kOperational);
}

}  // namespace
}  // namespace dualv::sim
