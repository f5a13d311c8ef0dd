// CanopenActuatorSet over the in-process bus with four scripted fake drives: enable without
// motion, torque scaling, stale targets, duplicate / late / out-of-order TPDOs, SYNC
// counter jumps, heartbeat timeout at T - 1 / T, EMCY, bus-off latch, ENOBUFS, broadcast
// layout, health, and zero allocations in read/write over 10,000 cycles.
#include "drivers/canopen_actuator_set.hpp"

#include <gtest/gtest.h>

#include <deque>
#include <memory>
#include <vector>

#include "common/config_error.hpp"
#include "drivers/canopen/cycle_clock.hpp"
#include "fake_slave.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::drivers {
namespace {

using test::FakeSlave;
constexpr std::uint64_t kMs = 1'000'000;

struct SetFixture : ::testing::Test {
  explicit SetFixture(fw::BusLayout layout = fw::BusLayout::kPerDrive) : hub(6, 1024) {
    config = default_can_config();
    config.bus_layout = layout;
    for (int i = 0; i < 4; ++i) {
      slaves.push_back(std::make_unique<FakeSlave>(hub.endpoint(static_cast<std::size_t>(i) + 1),
                                                   static_cast<std::uint8_t>(i + 1)));
      (void)slaves.back()->nmt.on_command(
          fw::NmtCommand::kStart);               // booted (boot_test covers boot)
      slaves.back()->configure_pdos(config, i);  // the PDOs as the master's boot writes them
      slaves.back()->position = 10000 * (i + 1);
    }
    set = std::make_unique<CanopenActuatorSet>(hub.endpoint(0), clock, config);
    cmd.n = 4;
  }
  InProcessBus& sniffer() { return hub.endpoint(5); }
  FakeSlave& slave(int i) { return *slaves[static_cast<std::size_t>(i)]; }

  // One control cycle: read, write, the drives answer the SYNC, time moves one period.
  IoStatus cycle(DriveRequest r = DriveRequest::kHold) {
    last_read = set->read(fb);
    cmd.request = r;
    const IoStatus w = set->write(cmd);
    for (auto& s : slaves) s->step();
    clock.advance_ns(kMs);
    hub.set_time_ns(clock.now_ns());
    return w;
  }
  void enable_all() {
    // Per-drive: a CiA 402 step a cycle. Broadcast: a step per can.controlword_inhibit
    // (10 ms), three steps.
    const int cycles = config.bus_layout == fw::BusLayout::kPerDrive ? 10 : 40;
    for (int i = 0; i < cycles; ++i) cycle(DriveRequest::kEnable);
    cycle(DriveRequest::kHold);
    for (int i = 0; i < 4; ++i) ASSERT_EQ(fb.drive[i].state, DriveState::kEnabled) << i;
  }
  // Target torques of RPDO1 frames on the wire since the last call, per node.
  std::vector<std::int16_t> wire_torques(std::uint8_t node) {
    std::vector<std::int16_t> out;
    for (const fw::CanFrame& f : test::drain(sniffer())) {
      if (f.id == fw::cob_id(fw::Function::kRpdo1, node) && f.dlc == 4)
        out.push_back(fw::decode_rpdo1(f)->target_torque);
      if (f.id == fw::kBroadcastRpdoCobId) out.push_back(*fw::decode_broadcast_torque(f, node - 1));
    }
    return out;
  }

  InProcessHub hub;
  canopen::ManualClock clock;
  CanConfig config;
  std::vector<std::unique_ptr<FakeSlave>> slaves;
  std::unique_ptr<CanopenActuatorSet> set;
  ActuatorFeedback fb;
  ActuatorCommand cmd;
  IoStatus last_read = IoStatus::kOk;
};

TEST_F(SetFixture, CycleOrderRpdosThenSync) {
  cycle();
  const auto wire = test::drain(sniffer());
  // RPDO1 for nodes 1..4 (controlword + torque), SYNC, the master's first heartbeat, then
  // the four TPDO1 answers.
  ASSERT_GE(wire.size(), 10u);
  EXPECT_EQ(test::to_text(wire[0]), "201#00000000");
  EXPECT_EQ(test::to_text(wire[3]), "204#00000000");
  EXPECT_EQ(test::to_text(wire[4]), "080#");
  EXPECT_EQ(test::to_text(wire[5]), "77F#05");
  EXPECT_EQ(wire[6].id, 0x181u);
  EXPECT_EQ(last_read, IoStatus::kNotReady);  // no TPDO yet at the very first read
  cycle();
  EXPECT_EQ(last_read, IoStatus::kOk);
  EXPECT_NEAR(fb.drive[1].position, 20000 * fw::kTwoPi / (1 << 20), 1e-12);
  EXPECT_TRUE(fb.drive[1].fresh);
}

TEST_F(SetFixture, EnableWithoutMotionThenTorqueInPerMille) {
  cmd.torque.fill(10.0);  // the controller already asks for torque while enabling
  for (int i = 0; i < 10; ++i) cycle(DriveRequest::kEnable);
  // On the wire: 0 until the drive's statusword said Operation enabled.
  const std::vector<std::int16_t> t = wire_torques(1);
  ASSERT_EQ(t.size(), 10u);
  int first_nonzero = -1;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (t[i] != 0 && first_nonzero < 0) first_nonzero = static_cast<int>(i);
  // RPDO1 is synchronous (type 1): the drive acts on a controlword at the SYNC after it and
  // its TPDO1 answer to that SYNC was sampled before (CiA 301 7.3.2), so a CiA 402 step
  // takes two cycles. Cycle 0: no statusword yet (disable voltage); cycles 1..2, 3..4, 5..6:
  // transitions 2, 3, 4 (each seen in the statusword one cycle later); cycle 7 reads
  // Operation enabled.
  EXPECT_EQ(first_nonzero, 7);
  EXPECT_EQ(t.back(), 200);                        // 10 N m of 50 N m rated = 200 per mille
  EXPECT_EQ(slave(0).applied_torques.front(), 0);  // no motion on enable
  EXPECT_EQ(fb.drive[0].state, DriveState::kEnabled);
  EXPECT_EQ(set->last_sent(0).torque_per_mille, 200);
  EXPECT_DOUBLE_EQ(fb.drive[0].torque_actual, 10.0);
}

TEST_F(SetFixture, StaleTargetNeverReplayedAfterReEnable) {
  enable_all();
  cmd.torque.fill(10.0);
  cycle();
  cmd.torque.fill(0.0);
  cycle(DriveRequest::kQuickStop);
  for (int i = 0; i < 3; ++i) cycle(DriveRequest::kQuickStop);
  EXPECT_EQ(slave(2).cia, fw::Cia402State::kQuickStopActive);
  (void)wire_torques(3);
  // Re-enable while the controller (wrongly) still holds the old 10 N m: the wire shows 0
  // during the whole walk (12, 2, 3, 4: eight cycles, two per step as RPDO1 acts at the SYNC
  // after it, its TPDO1 answer sampled before: CiA 301 7.3.2) and the drive never applies
  // the old 200 at re-entry; from the cycle that sees Operation enabled on, the current
  // command goes out.
  cmd.torque.fill(10.0);
  const std::size_t applied_before = slave(2).applied_torques.size();
  for (int i = 0; i < 10; ++i) cycle(DriveRequest::kEnable);
  const std::vector<std::int16_t> t = wire_torques(3);
  ASSERT_GE(t.size(), 10u);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(t[static_cast<std::size_t>(i)], 0) << i;
  EXPECT_EQ(t[8], 200);
  ASSERT_GT(slave(2).applied_torques.size(), applied_before);
  EXPECT_EQ(slave(2).applied_torques[applied_before], 0);
}

TEST_F(SetFixture, DuplicateAndLateTpdosCounted) {
  cycle();
  cycle();
  slave(1).send_tpdo();  // a duplicate of the one it sent after the last SYNC
  cycle();
  EXPECT_EQ(set->drive_counters(1).duplicates, 1u);
  EXPECT_TRUE(fb.drive[1].fresh);
  // A TPDO held back on the wire arrives together with the next one: the older is late,
  // the newest wins.
  hub.endpoint(3).delay_next(1, 6);  // drive 2's endpoint
  cycle();                           // drive 2's answer to this SYNC is held back
  slave(2).position += 5;
  cycle();
  EXPECT_FALSE(fb.drive[2].fresh);
  EXPECT_EQ(set->drive_counters(2).missed, 1u);
  cycle();
  EXPECT_TRUE(fb.drive[2].fresh);
  EXPECT_EQ(set->drive_counters(2).late, 1u);
  EXPECT_NEAR(fb.drive[2].position, 30005 * fw::kTwoPi / (1 << 20), 1e-12);
  EXPECT_EQ(set->drive_counters(0).late, 0u);
}

// A CanBus that hands out scripted frames with chosen timestamps (out-of-order test).
class ScriptedBus final : public CanBus {
 public:
  BusStatus send(const fw::CanFrame&) noexcept override { return BusStatus::kOk; }
  BusStatus receive(fw::CanFrame& f) noexcept override {
    if (frames.empty()) return BusStatus::kWouldBlock;
    f = frames.front();
    frames.pop_front();
    return BusStatus::kOk;
  }
  BusStatus state() const noexcept override { return BusStatus::kOk; }
  BusStatus restart() noexcept override { return BusStatus::kOk; }
  const BusCounters& counters() const noexcept override { return c; }
  std::deque<fw::CanFrame> frames;
  BusCounters c;
};

TEST(CanopenActuatorSetOrder, OutOfOrderTpdoCountedAndIgnored) {
  ScriptedBus bus;
  canopen::ManualClock clock;
  CanConfig c = default_can_config();
  c.drives.resize(1);
  CanopenActuatorSet set(bus, clock, c);
  fw::CanFrame newer = *fw::encode_tpdo1(1, {0x0237, 500});
  newer.timestamp_ns = 2000;
  fw::CanFrame older = *fw::encode_tpdo1(1, {0x0237, 400});
  older.timestamp_ns = 1000;
  bus.frames = {newer, older};
  ActuatorFeedback fb;
  set.read(fb);
  EXPECT_EQ(set.drive_counters(0).out_of_order, 1u);
  EXPECT_NEAR(fb.drive[0].position, 500 * fw::kTwoPi / (1 << 20), 1e-15);
}

TEST_F(SetFixture, ForeignSyncAndCounterJumpsCounted) {
  auto sync = [&](std::uint8_t n) { slave(3).send(fw::encode_sync(n)); };
  sync(1);
  sync(2);
  sync(5);  // jump
  sync(6);
  cycle();
  EXPECT_EQ(set->counters().foreign_sync, 4u);
  EXPECT_EQ(set->counters().sync_counter_jumps, 1u);
}

TEST_F(SetFixture, HeartbeatTimeoutAtExactlyT) {
  cycle();
  cycle();
  for (auto& s : slaves) s->send_heartbeat();
  const std::uint64_t t0 = clock.now_ns();
  set->read(fb);                                          // heartbeats processed at t0
  for (int i = 1; i < 4; ++i) slave(i).send_heartbeat();  // drive 0 goes silent
  clock.set_ns(t0 + config.drive_heartbeat_timeout_ns - 1);
  set->read(fb);
  EXPECT_NE(fb.drive[0].state, DriveState::kOffline);
  EXPECT_EQ(set->events().heartbeat_lost, 0u);
  clock.set_ns(t0 + config.drive_heartbeat_timeout_ns);
  set->read(fb);
  EXPECT_EQ(fb.drive[0].state, DriveState::kOffline);
  EXPECT_EQ(set->events().heartbeat_lost, 1u);
  EXPECT_EQ(set->health(0).health, DriveHealth::kStale);
  EXPECT_STREQ(set->health(0).reason, "heartbeat timed out");
  EXPECT_NE(fb.drive[1].state, DriveState::kOffline);
}

// The loop's clock (drivers/canopen/cycle_clock.hpp): a stamped cycle's read() and write() make
// no clock read of their own, and the drives' timeouts are judged at the cycle's wake-up.
TEST(CanopenActuatorSetCycleClock, ACycleReadsNoClockAndJudgesTimeoutsAtItsWakeUp) {
  struct CountingClock final : canopen::Clock {
    std::uint64_t now_ns() const noexcept override {
      ++reads;
      return t;
    }
    std::uint64_t t = 1'000 * kMs;
    mutable int reads = 0;
  } base;
  canopen::CycleClock clock(base);
  InProcessHub hub(5, 1024);
  const CanConfig config = default_can_config();
  std::vector<std::unique_ptr<FakeSlave>> slaves;
  for (int i = 0; i < 4; ++i) {
    slaves.push_back(std::make_unique<FakeSlave>(hub.endpoint(static_cast<std::size_t>(i) + 1),
                                                 static_cast<std::uint8_t>(i + 1)));
    (void)slaves.back()->nmt.on_command(fw::NmtCommand::kStart);  // booted
    slaves.back()->configure_pdos(config, i);  // the PDOs as the master's boot writes them
  }
  CanopenActuatorSet set(hub.endpoint(0), clock, config);
  ActuatorFeedback fb;
  ActuatorCommand cmd;
  cmd.n = 4;
  // One cycle woken at `wake` while the base clock says `base_now` (the cycle's work ran on).
  const auto cycle = [&](std::uint64_t wake, std::uint64_t base_now) {
    base.t = base_now;
    hub.set_time_ns(base_now);
    const int reads = base.reads;
    clock.begin_cycle(wake);
    set.read(fb);
    set.write(cmd);
    clock.end_cycle();
    EXPECT_EQ(base.reads, reads) << "a clock read inside the cycle woken at " << wake;
    for (auto& s : slaves) s->step();
  };
  cycle(1'000 * kMs, 1'000 * kMs);
  cycle(1'001 * kMs, 1'001 * kMs);
  for (auto& s : slaves) s->send_heartbeat();
  const std::uint64_t t0 = 1'002 * kMs;
  cycle(t0, t0);                                            // heartbeats taken at t0
  for (int i = 1; i < 4; ++i) slaves[i]->send_heartbeat();  // drive 0 goes silent
  const std::uint64_t timeout = config.drive_heartbeat_timeout_ns;
  cycle(t0 + timeout - 1, t0 + timeout + 5 * kMs);  // woken 1 ns before the timeout
  EXPECT_NE(fb.drive[0].state, DriveState::kOffline);
  EXPECT_EQ(set.events().heartbeat_lost, 0u);
  cycle(t0 + timeout, t0 + timeout + 6 * kMs);  // woken at the timeout
  EXPECT_EQ(fb.drive[0].state, DriveState::kOffline);
  EXPECT_EQ(set.events().heartbeat_lost, 1u);
  EXPECT_NE(fb.drive[1].state, DriveState::kOffline);
  // Outside a cycle (priming, shut-down) the set reads the base clock again.
  const int reads = base.reads;
  set.write(cmd);
  EXPECT_GT(base.reads, reads);
}

TEST_F(SetFixture, EmcyRaisesAndZeroClears) {
  enable_all();
  slave(1).fault(fw::emcy::kDeviceOverTemperature);
  cycle(DriveRequest::kHold);
  EXPECT_EQ(set->events().emcy_raised, 1u << 1);
  EXPECT_EQ(fb.drive[1].last_emcy, 0x4210);
  cycle(DriveRequest::kHold);
  EXPECT_EQ(fb.drive[1].state, DriveState::kFault);
  const DriveHealthReport h = set->health(1);
  EXPECT_EQ(h.health, DriveHealth::kError);
  EXPECT_EQ(h.last_emcy_code, 0x4210);
  EXPECT_STRNE(h.last_emcy_text, "none");
  EXPECT_EQ(h.own_stop, StopCause::kFault);
  const std::string line = describe(h);
  EXPECT_NE(
      line.find("node 2: ERROR (CiA 402 fault) NMT unknown, CiA 402 Fault, EMCY 4210h active"),
      std::string::npos)
      << line;
  EXPECT_NE(line.find("own stop: fault"), std::string::npos) << line;
  EXPECT_EQ(set->last_sent(1).torque_per_mille, 0);
  // Fault reset, then the drive's 0000h EMCY clears the error; the drive stays disabled.
  cycle(DriveRequest::kFaultReset);
  cycle(DriveRequest::kFaultReset);
  slave(1).send_emcy(fw::emcy::kNoError);
  cycle(DriveRequest::kHold);
  cycle(DriveRequest::kHold);
  EXPECT_EQ(set->events().emcy_raised, 0u);
  EXPECT_EQ(fb.drive[1].last_emcy, 0);
  EXPECT_EQ(fb.drive[1].state, DriveState::kDisabled);
  EXPECT_FALSE(set->health(1).emcy_active);
  EXPECT_EQ(set->health(1).last_emcy_code, 0x4210);
}

TEST_F(SetFixture, EstopInputSeenThroughTpdo2) {
  enable_all();
  slave(2).send_digital_inputs(fw::od::kDigitalInputEstopMask);
  cycle();
  EXPECT_TRUE(fb.drive[2].stop_input);
  EXPECT_FALSE(fb.drive[1].stop_input);
  EXPECT_EQ(set->events().stop_input, 1u << 2);
  EXPECT_EQ(set->health(2).health, DriveHealth::kWarn);
  EXPECT_STREQ(set->health(2).reason, "e-stop circuit open (60FDh)");
  cycle();
  EXPECT_EQ(set->events().stop_input, 0u);  // reported on the rising edge only
  slave(2).send_digital_inputs(0);
  cycle();
  EXPECT_FALSE(fb.drive[2].stop_input);
  fw::CanFrame short_frame;
  short_frame.id = 0x282;
  short_frame.dlc = 2;
  slave(1).send(fw::Result<fw::CanFrame>(short_frame));
  cycle();
  EXPECT_EQ(set->drive_counters(1).malformed, 1u);
}

TEST_F(SetFixture, NodeResetDuringOperationLosesTheDrive) {
  enable_all();
  slave(3).send(fw::encode_heartbeat(4, fw::NmtState::kBootUp));
  cycle(DriveRequest::kHold);
  EXPECT_EQ(set->events().boot_up, 1u << 3);
  EXPECT_EQ(fb.drive[3].state, DriveState::kOffline);
  EXPECT_EQ(set->last_sent(3).torque_per_mille, 0);
}

TEST_F(SetFixture, BusOffLatchedNoAutomaticReEnable) {
  enable_all();
  cmd.torque.fill(5.0);
  hub.endpoint(0).force_bus_off();
  EXPECT_EQ(cycle(DriveRequest::kHold), IoStatus::kBusError);
  EXPECT_EQ(last_read, IoStatus::kBusError);
  EXPECT_TRUE(set->bus_off_latched());
  EXPECT_TRUE(set->events().bus_off);
  (void)test::drain(sniffer());
  for (int i = 0; i < 5; ++i) EXPECT_EQ(cycle(DriveRequest::kHold), IoStatus::kBusError);
  EXPECT_TRUE(test::drain(sniffer()).empty());  // nothing sent while bus-off
  EXPECT_EQ(set->counters().bus_off, 1u);
  EXPECT_EQ(set->recover_bus(), BusStatus::kOk);
  EXPECT_FALSE(set->bus_off_latched());
  // The drives come back disabled by the host; kHold (the loop's running phase) never
  // re-enables them.
  for (int i = 0; i < 5; ++i) cycle(DriveRequest::kHold);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(fb.drive[i].state, DriveState::kDisabled) << i;
    EXPECT_EQ(set->last_sent(i).torque_per_mille, 0) << i;
  }
  // Three CiA 402 steps (2, 3, 4), each a cycle longer than the fake once took: RPDO1 acts
  // at the SYNC after it and the TPDO1 answering that SYNC was sampled before (CiA 301
  // 7.3.2); 4 cycles became 7, the budget 6 became 9.
  for (int i = 0; i < 9; ++i) cycle(DriveRequest::kEnable);
  EXPECT_EQ(fb.drive[0].state, DriveState::kEnabled);
}

TEST_F(SetFixture, BusOffThatRefusesRestartStaysLatched) {
  hub.endpoint(0).force_bus_off(true);
  cycle();
  EXPECT_EQ(set->recover_bus(), BusStatus::kBusOff);
  EXPECT_TRUE(set->bus_off_latched());
}

TEST_F(SetFixture, EnobufsCountedNothingSentLate) {
  enable_all();
  (void)test::drain(sniffer());
  cmd.torque.fill(1.0);
  hub.endpoint(0).fail_next_sends(2);  // RPDOs of nodes 1 and 2 refused this cycle
  EXPECT_EQ(cycle(DriveRequest::kHold), IoStatus::kBusError);
  EXPECT_EQ(set->counters().tx_would_block, 2u);
  EXPECT_FALSE(set->last_sent(0).sent);
  EXPECT_TRUE(set->last_sent(2).sent);
  cmd.torque.fill(2.0);
  EXPECT_EQ(cycle(DriveRequest::kHold), IoStatus::kOk);
  // Node 1 got exactly one RPDO, the new value; the refused one never went out later.
  EXPECT_EQ(wire_torques(1), std::vector<std::int16_t>{40});
}

TEST_F(SetFixture, StaleHealthAfterMissedTpdos) {
  enable_all();
  EXPECT_EQ(set->health(0).health, DriveHealth::kOk);
  slave(0).answers_sync = false;
  cmd.torque.fill(3.0);
  cycle();
  cycle();
  EXPECT_EQ(last_read, IoStatus::kStale);
  EXPECT_EQ(set->health(0).health, DriveHealth::kWarn);
  // One missed TPDO is jitter, not a lost drive: its torque keeps flowing.
  EXPECT_EQ(set->last_sent(0).torque_per_mille, 60);
  cycle();
  cycle();
  EXPECT_EQ(set->health(0).health, DriveHealth::kStale);
  EXPECT_FALSE(fb.drive[0].fresh);
  // No fresh statusword: no torque to that drive.
  cmd.torque.fill(3.0);
  cycle();
  EXPECT_EQ(set->last_sent(0).torque_per_mille, 0);
  EXPECT_NE(set->last_sent(1).torque_per_mille, 0);
}

TEST_F(SetFixture, WrongCommandShapeDisables) {
  enable_all();
  cmd.n = 3;
  EXPECT_EQ(cycle(DriveRequest::kHold), IoStatus::kBusError);
  // The disabling controlword acts at the SYNC after it, the TPDO1 answering that SYNC was
  // sampled before (CiA 301 7.3.2): the next statusword shows it.
  cycle(DriveRequest::kHold);
  cycle(DriveRequest::kHold);
  EXPECT_EQ(fb.drive[0].state, DriveState::kDisabled);
}

TEST_F(SetFixture, ZeroAllocationsInReadWriteOver10000Cycles) {
  enable_all();
  long in_cycle = 0;
  for (int k = 0; k < 10000; ++k) {
    cmd.torque.fill(0.001 * (k % 100));
    const long before = dualv::test::allocation_count();
    set->read(fb);
    cmd.request = DriveRequest::kHold;
    set->write(cmd);
    (void)set->health(k % 4);
    in_cycle += dualv::test::allocation_count() - before;
    for (auto& s : slaves) {  // the fake drives may allocate; they are not measured
      s->applied_torques.clear();
      s->controlwords.clear();
      s->step();
    }
    clock.advance_ns(kMs);
    hub.set_time_ns(clock.now_ns());
    if (k % 50 == 0)
      for (auto& s : slaves) s->send_heartbeat();
  }
  EXPECT_EQ(in_cycle, 0);
  EXPECT_EQ(fb.drive[3].state, DriveState::kEnabled);
  EXPECT_GT(set->counters().heartbeats_sent, 100u);
}

TEST_F(SetFixture, ServiceKeepsTheMasterHeartbeatWithoutSync) {
  clock.advance_ns(60 * kMs);
  set->service();
  const auto wire = test::drain(sniffer());
  ASSERT_EQ(wire.size(), 1u);
  EXPECT_EQ(test::to_text(wire[0]), "77F#05");
}

TEST(CanopenActuatorSetSetup, SyncCounterOnTheWire) {
  InProcessHub hub(2);
  canopen::ManualClock clock;
  CanConfig c = default_can_config();
  c.sync_counter_overflow = 2;
  // Per-drive with a counter: 905 bits a cycle, 90.5 % at 1 kHz: above can.max_cyclic_load
  // (90 %, issue 15), refused. The broadcast layout carries it: 65 + 135 + 4 x 95 = 580.
  EXPECT_THROW(CanopenActuatorSet(hub.endpoint(0), clock, c), ConfigError);
  c.bus_layout = fw::BusLayout::kBroadcast;
  CanopenActuatorSet set(hub.endpoint(0), clock, c);
  ActuatorCommand cmd;
  cmd.n = 4;
  std::vector<std::string> syncs;
  for (int k = 0; k < 3; ++k) {
    set.write(cmd);
    for (const auto& f : test::drain(hub.endpoint(1)))
      if (f.id == 0x080) syncs.push_back(test::to_text(f));
  }
  EXPECT_EQ(syncs, (std::vector<std::string>{"080#01", "080#02", "080#01"}));
  EXPECT_EQ(set.bus_load().cyclic_bits.total(), 580u);  // SYNC with one byte: 65 bits, not 55
}

TEST(CanopenActuatorSetSetup, RefusesARateTheBusCannotCarry) {
  InProcessHub hub(2);
  canopen::ManualClock clock;
  CanConfig c = default_can_config();
  c.sync_period_ns = 500'000;
  EXPECT_THROW(CanopenActuatorSet(hub.endpoint(0), clock, c), ConfigError);
}

struct BroadcastFixture : SetFixture {
  BroadcastFixture() : SetFixture(fw::BusLayout::kBroadcast) {}
};

TEST_F(BroadcastFixture, OneTorqueFrameControlwordsOnChange) {
  cycle();
  auto wire = test::drain(sniffer());
  EXPECT_EQ(test::to_text(wire[0]), "201#0000");  // controlword RPDO, first time
  EXPECT_EQ(test::to_text(wire[4]), "200#0000000000000000");
  EXPECT_EQ(test::to_text(wire[5]), "080#");
  cycle();
  wire = test::drain(sniffer());
  EXPECT_EQ(test::to_text(wire[0]), "200#0000000000000000");  // no controlword: unchanged
  enable_all();
  cmd.torque = {1.0, 2.0, -1.0, 0.5};
  (void)test::drain(sniffer());
  cycle();
  wire = test::drain(sniffer());
  EXPECT_EQ(test::to_text(wire[0]), "200#14002800ECFF0A00");  // 20, 40, -20, 10 per mille
  EXPECT_EQ(slave(2).target_torque, -20);
  EXPECT_EQ(set->bus_load().cyclic_bits.total(), 570u);  // 55 + 135 + 4 x 95
}

TEST_F(BroadcastFixture, PositionEveryCycleStatuswordOnChange) {
  cycle();
  // Answering the first SYNC: four position TPDO1s (4 B) and, the first time, four TPDO3s.
  auto wire = test::drain(sniffer());
  int positions = 0, statuswords = 0;
  for (const auto& f : wire) {
    positions += f.id >= 0x181 && f.id <= 0x184;
    statuswords += f.id >= 0x381 && f.id <= 0x384;
    if (f.id == 0x182) {
      EXPECT_EQ(test::to_text(f), "182#204E0000");  // 20000 counts
    }
  }
  EXPECT_EQ(positions, 4);
  EXPECT_EQ(statuswords, 4);
  cycle();  // its read() takes them
  EXPECT_EQ(last_read, IoStatus::kOk);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(fb.drive[i].fresh) << i;
  EXPECT_NEAR(fb.drive[1].position, 20000.0 / (1 << 20) * 2 * 3.14159265358979, 1e-9);
  wire = test::drain(sniffer());  // the second SYNC's answers
  statuswords = 0;
  for (const auto& f : wire) statuswords += f.id >= 0x381 && f.id <= 0x384;
  EXPECT_EQ(statuswords, 0);  // unchanged: none
  // The host still knows every drive's state from the TPDO3s and enables them.
  enable_all();
  for (int i = 0; i < 4; ++i) EXPECT_EQ(set->drive(i).state(), fw::Cia402State::kOperationEnabled);
  EXPECT_GE(set->drive_counters(0).statuswords, 4u);  // one per state on the way
}

TEST_F(BroadcastFixture, SilentStatuswordMakesTheDriveStale) {
  enable_all();
  // Drive 3 stops its statusword TPDO3 but keeps sending positions: after
  // ceil(statusword_refresh / period) + stale_cycles = 100 + 3 cycles without one, the host
  // no longer trusts its state (feedback not fresh, health STALE, torque 0).
  const int bound = 100 + 3;
  for (int k = 0; k < bound + 5; ++k) {
    // The others' statusword comes as their event timer would send it; drive 3's once.
    for (int i = 0; i < 4; ++i)
      if ((i != 2 && k % 50 == 0) || k == 0)
        slave(i).send(
            fw::encode_statusword_tpdo(static_cast<std::uint8_t>(i + 1), slave(i).statusword()));
    cmd.torque = {1.0, 1.0, 1.0, 1.0};
    cycle(DriveRequest::kHold);
    // Read k sees the statusword k cycles old: fresh up to the bound, stale after it.
    EXPECT_EQ(fb.drive[2].fresh, k <= bound) << k;
  }
  EXPECT_FALSE(fb.drive[2].fresh);
  EXPECT_TRUE(fb.drive[0].fresh);
  EXPECT_EQ(set->health(2).health, DriveHealth::kStale);
  EXPECT_EQ(std::string(set->health(2).reason),
            "no statusword (TPDO3) within can.statusword_refresh");
  EXPECT_EQ(set->last_sent(2).torque_per_mille, 0);
  EXPECT_EQ(set->last_sent(0).torque_per_mille, 20);
}

TEST_F(BroadcastFixture, ControlwordChangeWaitsOutTheInhibitTime) {
  const std::uint64_t t0 = clock.now_ns();
  cycle();  // t0: the first controlwords
  (void)test::drain(sniffer());
  // Ask for enable 1 ms later: the change (0006h shutdown) waits until t0 + 10 ms
  // (can.controlword_inhibit), each later step 10 ms after the one before.
  std::vector<std::uint64_t> cw_times;
  for (int k = 1; k < 30; ++k) {
    const std::uint64_t t = clock.now_ns();
    cycle(DriveRequest::kEnable);
    for (const auto& f : test::drain(sniffer()))
      if (f.id == 0x201) cw_times.push_back(t);
  }
  ASSERT_GE(cw_times.size(), 2u);
  EXPECT_EQ(cw_times[0] - t0, 10 * kMs);
  EXPECT_GE(cw_times[1] - cw_times[0], 10 * kMs);
  for (std::size_t k = 1; k < cw_times.size(); ++k)
    EXPECT_GE(cw_times[k] - cw_times[k - 1], 10 * kMs);
}

TEST_F(BroadcastFixture, ControlwordRefreshedPeriodically) {
  for (int i = 0; i < 150; ++i) cycle();
  int cw_frames = 0;
  for (const auto& f : test::drain(sniffer())) cw_frames += f.id == 0x201;
  EXPECT_EQ(cw_frames, 2);  // first cycle + one refresh after can.controlword_refresh (0.1 s)
}

}  // namespace
}  // namespace dualv::drivers
