// A bus attacker against the whole stack on the in-process CAN rig (sim/in_process_can_rig.hpp):
// the CANopen master's actuator set (drivers/canopen_actuator_set.hpp), booted over frames,
// and the control cycle with its safety filter (control/loop/control_cycle.hpp) running the
// paper program, while the fuzzer puts frames of its own on the bus each cycle (forged TPDOs,
// EMCYs, heartbeats, SDO answers, NMT commands, anything). The invariants are checked on the
// wire, on the frames the master sends as the monitor endpoint captures them, decoded with
// firmware_if (independent of the stack's own variables):
//   - no RPDO carries a target torque above safety.torque.max (config/dualv.yaml), in per
//     mille of the drive's rated torque, rounded as the wire rounds (half a per mille);
//   - once the safety filter reports STO, every RPDO the master sends carries 0 torque.
// The attacker transmits on the monitor endpoint, so its own frames (never echoed back to
// the sender) are not mistaken for the master's.
//
// Input, per control cycle: a byte c (bits 0..1: frames to inject, 0..3; bit 2: inject after
// the master's cycle instead of before; bit 3: the frame's id is taken from the CiA 301 set
// the drives use, fuzz/frame_input.hpp otherwise), then the frames (12 bytes each).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "apps/experiment/robot_config.hpp"
#include "control/loop/control_cycle.hpp"
#include "control/trajectory/program.hpp"
#include "drivers/canopen_config.hpp"
#include "drivers/canopen_setup.hpp"
#include "firmware_if/firmware_if.hpp"
#include "fuzz/check.hpp"
#include "fuzz/frame_input.hpp"
#include "sim/in_process_can_rig.hpp"
#include "tests/support/can_rig_time.hpp"

namespace fw = dualv::fw;
namespace drivers = dualv::drivers;

namespace {

constexpr int kMaxCycles = 400;   // attacked cycles per input
constexpr int kQuietCycles = 20;  // then the stack runs on without the attacker

const std::string& config_file() {
  static const std::string f = std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml";
  return f;
}
const dualv::apps::RobotConfig& robot() {
  static const dualv::apps::RobotConfig cfg = dualv::apps::load_robot_config(config_file());
  return cfg;
}
const drivers::CanConfig& can() {
  static const drivers::CanConfig c = drivers::load_can_config_file(config_file());
  return c;
}
const dualv::trajectory::Program& paper() {
  static const dualv::trajectory::Program p = [] {
    dualv::trajectory::ProgramContext ctx;
    ctx.start = ctx.home = robot().model.home;
    return dualv::trajectory::load_program_file(
        std::string(DUALV_SOURCE_DIR) + "/config/paper.yaml", ctx);
  }();
  return p;
}

using dualv::test::RigClock;
using dualv::test::RigWaiter;

// The largest |per mille| the safety limit allows on drive i: safety.torque.max in per mille
// of the rated torque, plus the half per mille the wire's rounding adds.
double limit_per_mille(int i) {
  return robot().safety.torque.max * 1000.0 /
             can().drives[static_cast<std::size_t>(i)].rated_torque +
         0.5;
}

struct Stack {
  Stack()
      : rig(robot().model, robot().plant, can()),
        clock(rig),
        waiter(rig),
        drives(drivers::boot_actuator_set(rig.master_bus(), clock, waiter, can())),
        cycle(robot().model, robot().control, {robot().period(), 2.0, robot().safety}) {
    drain_monitor();
    cycle.start(*drives, paper(), robot().trajectory.rebase);
  }

  // Every frame the master and the drives sent since the last call; checks the master's RPDOs.
  void drain_monitor() {
    fw::CanFrame f;
    while (rig.monitor_bus().receive(f) == drivers::BusStatus::kOk) {
      if (f.extended || f.rtr) continue;
      if (f.id == fw::kBroadcastRpdoCobId && can().bus_layout == fw::BusLayout::kBroadcast) {
        const auto b = fw::decode_broadcast_torques(f);
        FUZZ_CHECK(b.ok());
        for (int i = 0; i < b->drives; ++i) observe(i, b->torque[static_cast<std::size_t>(i)]);
        continue;
      }
      if (f.id <= fw::kRpdo1Base || f.id > fw::kRpdo1Base + fw::kMaxNodeId) continue;
      const int drive = can().drive_of_node(static_cast<std::uint8_t>(f.id - fw::kRpdo1Base));
      if (drive < 0) continue;
      if (can().bus_layout == fw::BusLayout::kPerDrive) {
        const auto c = fw::decode_rpdo1(f);
        FUZZ_CHECK(c.ok());  // the master's RPDO1 is always the contract's layout
        observe(drive, c->target_torque);
      }
    }
  }
  void observe(int drive, std::int16_t per_mille) {
    ++rpdos;
    FUZZ_CHECK(std::abs(static_cast<double>(per_mille)) <= limit_per_mille(drive));
    if (sto) FUZZ_CHECK(per_mille == 0);
  }

  void step() {
    (void)cycle.step(*drives, rec);
    if (rec.safety.state == dualv::safety::SafetyState::kSto) sto = true;  // latched until reset
    rig.step(static_cast<std::uint64_t>(robot().loop.period_ns));
    drain_monitor();
    dualv::safety::FaultEvent e;
    while (cycle.safety().log().try_pop(e)) {
    }
  }

  dualv::sim::InProcessCanRig rig;
  RigClock clock;
  RigWaiter waiter;
  std::unique_ptr<drivers::CanopenActuatorSet> drives;
  dualv::control::ControlCycle cycle;
  dualv::control::CycleRecord rec;
  bool sto = false;
  long rpdos = 0;  // the master's RPDOs seen on the wire
};

// How often the attacks reached STO (printed at exit: the zero-torque invariant was exercised).
struct Tally {
  long inputs = 0, stopped = 0;
  ~Tally() {
    if (inputs > 0)
      std::fprintf(stderr, "bus_attack: %ld inputs, %ld of them drove the stack to STO\n", inputs,
                   stopped);
  }
};
Tally tally;

fw::CanFrame attack_frame(FuzzedDataProvider& in, bool contract_id) {
  fw::CanFrame f = dualv::fuzz::consume_frame(in);
  if (contract_id) {
    // The ids the drives and the master use (CiA 301 predefined set, nodes of the config).
    static constexpr std::uint16_t kBases[] = {fw::kNmtCobId,  fw::kSyncCobId,    fw::kEmcyBase,
                                               fw::kTpdo1Base, fw::kRpdo1Base,    fw::kSdoTxBase,
                                               fw::kSdoRxBase, fw::kHeartbeatBase};
    const std::uint16_t base = kBases[f.id % std::size(kBases)];
    const bool has_node = base != fw::kNmtCobId && base != fw::kSyncCobId;
    const auto& d = can().drives[(f.id >> 3) % can().drives.size()];
    f.id = base + (has_node ? d.node_id : 0u);
    f.extended = false;
  }
  return f;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  Stack s;
  for (int k = 0; k < kMaxCycles && in.remaining_bytes() > 0; ++k) {
    const std::uint8_t c = in.ConsumeIntegral<std::uint8_t>();
    const int n = c & 3;
    const bool after = (c & 4u) != 0;
    if (!after)
      for (int j = 0; j < n; ++j) (void)s.rig.monitor_bus().send(attack_frame(in, (c & 8u) != 0));
    (void)s.cycle.step(*s.drives, s.rec);
    if (s.rec.safety.state == dualv::safety::SafetyState::kSto) s.sto = true;
    if (after)
      for (int j = 0; j < n; ++j) (void)s.rig.monitor_bus().send(attack_frame(in, (c & 8u) != 0));
    s.rig.step(static_cast<std::uint64_t>(robot().loop.period_ns));
    s.drain_monitor();
    dualv::safety::FaultEvent e;
    while (s.cycle.safety().log().try_pop(e)) {
    }
  }
  for (int k = 0; k < kQuietCycles; ++k) s.step();
  // Not vacuous: the master kept sending RPDOs (every cycle, whatever the attacker does).
  FUZZ_CHECK(s.rpdos > 0);
  ++tally.inputs;
  tally.stopped += s.sto ? 1 : 0;
  return 0;
}
