// The PDO engine part of the emulated slave (sim/canopen/pdo_engine.hpp) with frames alone:
// every frame and abort code below is written by hand from CiA 301 (7.2.2 PDO, 7.4.7.1
// mapping incl. dummy entries, 7.5.2.35..38 the records, inhibit time and event timer).
#include "sim/canopen/pdo_engine.hpp"

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "tests/support/allocation_counter.hpp"

namespace dualv::sim::canopen {
namespace {

constexpr std::uint8_t kNode = 5;
using fw::od::PdoDirection;

fw::CanFrame frame(std::uint32_t id, std::vector<std::uint8_t> bytes) {
  fw::CanFrame f;
  f.id = id;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) f.data[i] = bytes[i];
  return f;
}
std::vector<std::uint8_t> bytes_of(const fw::CanFrame& f) {
  return {f.data.begin(), f.data.begin() + f.dlc};
}

struct Recorder final : PdoHooks {
  std::vector<fw::CanFrame> sent;
  std::vector<int> written_slots;
  int samples = 0;
  void transmit(const fw::CanFrame& f) noexcept override { sent.push_back(f); }
  void written(int slot, std::uint64_t) noexcept override { written_slots.push_back(slot); }
  void before_sample() noexcept override { ++samples; }
};

struct Engine : ::testing::Test {
  ObjectDictionary od;
  PdoEngine engine;
  Recorder hooks;
  int s_cw = -1, s_sw = -1, s_tt = -1, s_pos = -1;
  void SetUp() override {
    s_cw = od.add(fw::od::kControlword, 0);
    s_sw = od.add(fw::od::kStatusword, 0);
    s_tt = od.add(fw::od::kTargetTorque, 0);
    s_pos = od.add(fw::od::kPositionActual, 0);
    PdoEngine::add_objects(od, kNode);
    engine.rebuild(od);
  }
  // An SDO download as the slave performs it: checked, stored, records re-read.
  std::uint32_t write(std::uint16_t index, std::uint8_t sub, std::uint32_t v) {
    const int slot = od.find(index, sub);
    EXPECT_GE(slot, 0) << std::hex << index << " sub " << int(sub);
    const std::uint32_t a = engine.check_write(od, od.entry(slot), v);
    if (a == 0) {
      od.set(slot, v);
      engine.rebuild_pdo_of(od, index);
    }
    return a;
  }
  std::uint32_t read(std::uint16_t index, std::uint8_t sub) const {
    return od.u(od.find(index, sub));
  }
};

TEST_F(Engine, RecordsHaveSub0AndTheContractDefaults) {
  // Communication records: sub0 = 5 (highest sub-index supported); mapping: sub0 = entries.
  for (int index : {0x1400, 0x1401, 0x1402, 0x1403, 0x1800, 0x1801, 0x1802, 0x1803})
    EXPECT_EQ(read(static_cast<std::uint16_t>(index), 0), 5u) << std::hex << index;
  EXPECT_EQ(read(0x1400, 1), 0x40000205u);  // RPDO1 on 200h + 5, valid, no RTR (bit 30)
  EXPECT_EQ(read(0x1800, 1) & 0x7FFu, 0x185u);
  EXPECT_EQ(read(0x1800, 1) >> 31, 0u);
  EXPECT_EQ(read(0x1401, 1) >> 31, 1u);  // RPDO2 not valid
  EXPECT_EQ(read(0x1600, 0), 2u);
  EXPECT_EQ(read(0x1600, 1), 0x60400010u);  // controlword, 16 bits
  EXPECT_EQ(read(0x1600, 2), 0x60710010u);  // target torque, 16 bits
  EXPECT_EQ(read(0x1A00, 0), 2u);
  EXPECT_EQ(read(0x1A00, 1), 0x60410010u);  // statusword
  EXPECT_EQ(read(0x1A00, 2), 0x60640020u);  // position actual, 32 bits
  EXPECT_EQ(read(0x1601, 0), 0u);
}

TEST_F(Engine, SynchronousRpdoIsLatchedAtTheNextSync) {
  // 205#0F00E803: controlword 000Fh, target torque 03E8h = 1000 per mille.
  const RpdoReceipt r = engine.on_rpdo(frame(0x205, {0x0F, 0x00, 0xE8, 0x03}), true, od, hooks, 0);
  EXPECT_TRUE(r.mine);
  EXPECT_TRUE(r.accepted);
  EXPECT_EQ(r.pdo, 1);
  EXPECT_EQ(od.u(s_cw), 0u);  // type 1: not before the SYNC (CiA 301 7.2.2.2)
  engine.latch_at_sync(od, hooks, 1);
  EXPECT_EQ(od.u(s_cw), 0x000Fu);
  EXPECT_EQ(od.i(s_tt), 1000);
  EXPECT_EQ(hooks.written_slots, (std::vector<int>{s_cw, s_tt}));
  EXPECT_TRUE(engine.maps(PdoDirection::kRpdo, 1, 0x6071));
  EXPECT_FALSE(engine.maps(PdoDirection::kRpdo, 1, 0x6064));
}

TEST_F(Engine, WritingOnePdosRecordLeavesTheOthersRunning) {
  // An RPDO1 received, to be latched at the next SYNC (type 1).
  ASSERT_TRUE(engine.on_rpdo(frame(0x205, {0x0F, 0x00, 0xE8, 0x03}), true, od, hooks, 0).accepted);
  // RPDO2's and TPDO2's records written meanwhile (CiA 301 7.5.2.35/37: each PDO its own
  // record): RPDO1 keeps its pending data.
  EXPECT_EQ(write(0x1401, 2, 1), 0u);
  EXPECT_EQ(write(0x1801, 2, 1), 0u);
  engine.latch_at_sync(od, hooks, 1);
  EXPECT_EQ(od.u(s_cw), 0x000Fu);
  EXPECT_EQ(od.i(s_tt), 1000);
  // Its own record written: RPDO1 starts over, what it held is dropped.
  ASSERT_TRUE(engine.on_rpdo(frame(0x205, {0x06, 0x00, 0x10, 0x00}), true, od, hooks, 2).accepted);
  EXPECT_EQ(write(0x1400, 2, 1), 0u);
  engine.latch_at_sync(od, hooks, 3);
  EXPECT_EQ(od.u(s_cw), 0x000Fu);
  EXPECT_EQ(od.i(s_tt), 1000);
}

TEST_F(Engine, NotProcessedOutsideOperationalButRecognised) {
  const RpdoReceipt r = engine.on_rpdo(frame(0x205, {0x0F, 0x00, 0xE8, 0x03}), false, od, hooks, 0);
  EXPECT_TRUE(r.mine);
  EXPECT_FALSE(r.accepted);
  engine.latch_at_sync(od, hooks, 1);
  EXPECT_EQ(od.u(s_cw), 0u);
  EXPECT_FALSE(engine.on_rpdo(frame(0x206, {0, 0, 0, 0}), true, od, hooks, 0).mine);
}

TEST_F(Engine, ShortRpdoIsNotProcessed) {
  // 3 bytes for a 4-byte mapping: a length error (EMCY 8210h by the slave), nothing written.
  const RpdoReceipt r = engine.on_rpdo(frame(0x205, {0x0F, 0x00, 0xE8}), true, od, hooks, 0);
  EXPECT_TRUE(r.mine);
  EXPECT_TRUE(r.too_short);
  EXPECT_FALSE(r.accepted);
  engine.latch_at_sync(od, hooks, 1);
  EXPECT_EQ(od.u(s_cw), 0u);
  // A longer frame is fine (the extra byte is ignored).
  EXPECT_TRUE(
      engine.on_rpdo(frame(0x205, {0x06, 0x00, 0x10, 0x00, 0xFF}), true, od, hooks, 2).accepted);
}

TEST_F(Engine, DummyEntriesSkipTheirBytes) {
  // RPDO2 as a broadcast slot: [dummy UNSIGNED16 (0006h)] [6071h], event-driven (type 255).
  EXPECT_EQ(write(0x1401, 2, 0xFF), 0u);
  EXPECT_EQ(write(0x1601, 0, 0), 0u);
  EXPECT_EQ(write(0x1601, 1, 0x00060010u), 0u);
  EXPECT_EQ(write(0x1601, 2, 0x60710010u), 0u);
  EXPECT_EQ(write(0x1601, 0, 2), 0u);
  EXPECT_EQ(write(0x1401, 1, 0x305), 0u);  // valid on 305h
  const RpdoReceipt r = engine.on_rpdo(frame(0x305, {0xAA, 0xBB, 0x2C, 0x01}), true, od, hooks, 0);
  EXPECT_TRUE(r.accepted);
  EXPECT_EQ(od.i(s_tt), 300);  // 012Ch, written at once (type 255)
  EXPECT_EQ(od.u(s_cw), 0u);   // the dummy's bytes AAh BBh went nowhere
  EXPECT_EQ(hooks.written_slots, (std::vector<int>{s_tt}));
  EXPECT_EQ(engine.length(PdoDirection::kRpdo, 2), 4);
}

TEST_F(Engine, MappingRulesAbortWithTheStandardsCodes) {
  // While valid: 06010000h (unsupported access), CiA 301 7.5.2.36.
  EXPECT_EQ(write(0x1600, 0, 0), 0x06010000u);
  EXPECT_EQ(write(0x1400, 1, 0x80000205u), 0u);  // invalidate
  // An entry while sub0 != 0: 06010000h.
  EXPECT_EQ(write(0x1600, 1, 0x60710010u), 0x06010000u);
  EXPECT_EQ(write(0x1600, 0, 0), 0u);
  // Dummy with the wrong length (UNSIGNED16 as 8 bits): 06040041h at sub0 = n.
  EXPECT_EQ(write(0x1600, 1, 0x00060008u), 0u);
  EXPECT_EQ(write(0x1600, 0, 1), 0x06040041u);
  // An object not in the dictionary: 06020000h.
  EXPECT_EQ(write(0x1600, 1, 0x20000010u), 0u);
  EXPECT_EQ(write(0x1600, 0, 1), 0x06020000u);
  // Read-only statusword into an RPDO: 06040041h.
  EXPECT_EQ(write(0x1600, 1, 0x60410010u), 0u);
  EXPECT_EQ(write(0x1600, 0, 1), 0x06040041u);
  // 3 x 32 bits = 12 bytes on a classic drive: 06040042h.
  for (std::uint8_t s = 1; s <= 3; ++s) EXPECT_EQ(write(0x1600, s, 0x00070020u), 0u);
  EXPECT_EQ(write(0x1600, 0, 3), 0x06040042u);
  // 9 entries: more than sub-indices 1..8.
  EXPECT_EQ(write(0x1600, 0, 9), 0x06040042u);
  // A dummy in a TPDO: 06040041h.
  EXPECT_EQ(write(0x1801, 1, 0x80000285u), 0u);
  EXPECT_EQ(write(0x1A01, 1, 0x00060010u), 0u);
  EXPECT_EQ(write(0x1A01, 0, 1), 0x06040041u);
  // The COB-ID of a valid PDO cannot change (7.5.2.35); transmission type 241 is reserved.
  EXPECT_EQ(write(0x1800, 1, 0x00000186u), 0x06090030u);
  EXPECT_EQ(write(0x1800, 2, 241), 0x06090030u);
}

TEST_F(Engine, RefusingDummiesIsADrivesChoice) {
  engine.configure({false, true});
  EXPECT_EQ(write(0x1400, 1, 0x80000205u), 0u);
  EXPECT_EQ(write(0x1600, 0, 0), 0u);
  EXPECT_EQ(write(0x1600, 1, 0x00060010u), 0x06040041u);
}

TEST_F(Engine, SynchronousTpdoCarriesTheMappedObjects) {
  od.set(s_sw, 0x0237);
  od.set(s_pos, 0x12345678);
  engine.transmit_at_sync(od, hooks, 0);
  ASSERT_EQ(hooks.sent.size(), 1u);
  EXPECT_EQ(hooks.sent[0].id, 0x185u);
  EXPECT_EQ(bytes_of(hooks.sent[0]),
            (std::vector<std::uint8_t>{0x37, 0x02, 0x78, 0x56, 0x34, 0x12}));
  // Type 2: every second SYNC.
  EXPECT_EQ(write(0x1800, 2, 2), 0u);
  hooks.sent.clear();
  for (int k = 1; k <= 4; ++k) engine.transmit_at_sync(od, hooks, k * 1'000'000ull);
  EXPECT_EQ(hooks.sent.size(), 2u);
}

// TPDO2 = statusword, event-driven (255), inhibit time 10 x 100 us = 1 ms.
struct EventTpdo : Engine {
  void SetUp() override {
    Engine::SetUp();
    EXPECT_EQ(write(0x1A01, 1, 0x60410010u), 0u);
    EXPECT_EQ(write(0x1A01, 0, 1), 0u);
    EXPECT_EQ(write(0x1801, 3, 10), 0u);
    EXPECT_EQ(write(0x1801, 1, 0x285), 0u);
  }
};

TEST_F(EventTpdo, InhibitTimeHoldsAChangeUntilItEnds) {
  hooks.sent.clear();
  od.set(s_sw, 0x0250);
  engine.transmit_at_sync(od, hooks, 0);  // first: sent (TPDO1 too)
  auto tpdo2 = [&] {
    int n = 0;
    for (const fw::CanFrame& f : hooks.sent) n += f.id == 0x285u;
    return n;
  };
  EXPECT_EQ(tpdo2(), 1);
  od.set(s_sw, 0x0231);
  engine.transmit_at_sync(od, hooks, 500'000);  // changed inside the inhibit time: held
  EXPECT_EQ(tpdo2(), 1);
  EXPECT_EQ(engine.next_due_ns(500'000), 1'000'000u);
  od.set(s_sw, 0x0233);
  engine.on_time(od, hooks, 999'999);  // T - 1 ns
  EXPECT_EQ(tpdo2(), 1);
  engine.on_time(od, hooks, 1'000'000);  // T: sent with the data of that moment
  ASSERT_EQ(tpdo2(), 2);
  EXPECT_EQ(bytes_of(hooks.sent.back()), (std::vector<std::uint8_t>{0x33, 0x02}));
  // No change: nothing at the next SYNCs.
  engine.transmit_at_sync(od, hooks, 3'000'000);
  EXPECT_EQ(tpdo2(), 2);
}

TEST_F(EventTpdo, EventTimerResendsAfterItsPeriod) {
  EXPECT_EQ(write(0x1801, 1, 0x80000285u), 0u);
  EXPECT_EQ(write(0x1801, 5, 5), 0u);  // 5 ms
  EXPECT_EQ(write(0x1801, 1, 0x285), 0u);
  od.set(s_sw, 0x0250);
  engine.transmit_at_sync(od, hooks, 0);
  hooks.sent.clear();
  engine.on_time(od, hooks, 4'999'999);
  EXPECT_TRUE(hooks.sent.empty());
  engine.on_time(od, hooks, 5'000'000);
  ASSERT_EQ(hooks.sent.size(), 1u);
  EXPECT_EQ(hooks.sent[0].id, 0x285u);
  EXPECT_EQ(hooks.samples, 1);  // live values refreshed before sampling
}

TEST_F(Engine, RpdoDeadlineExpiresAtTheEventTime) {
  EXPECT_EQ(write(0x1400, 5, 10), 0u);                  // 10 ms deadline monitoring
  EXPECT_EQ(engine.expired_deadlines(100'000'000), 0);  // not armed before the first RPDO
  engine.on_rpdo(frame(0x205, {0x0F, 0x00, 0x00, 0x00}), true, od, hooks, 1'000'000);
  EXPECT_EQ(engine.next_due_ns(1'000'000), 11'000'000u);
  EXPECT_EQ(engine.expired_deadlines(10'999'999), 0);  // T - 1 ns
  EXPECT_EQ(engine.expired_deadlines(11'000'000), 1);  // T
  EXPECT_EQ(engine.expired_deadlines(12'000'000), 0);  // once
  engine.on_rpdo(frame(0x205, {0x0F, 0x00, 0x00, 0x00}), true, od, hooks, 20'000'000);
  engine.stop();  // leaving Operational: no monitoring, nothing pending
  EXPECT_EQ(engine.expired_deadlines(40'000'000), 0);
  engine.latch_at_sync(od, hooks, 40'000'000);
  EXPECT_EQ(od.u(s_cw), 0u);
}

// The real-time path of the part: reception, SYNC, timers allocate nothing.
struct Counting final : PdoHooks {
  long sent = 0, writes = 0;
  void transmit(const fw::CanFrame&) noexcept override { ++sent; }
  void written(int, std::uint64_t) noexcept override { ++writes; }
  void before_sample() noexcept override {}
};

TEST_F(EventTpdo, FramePathAllocatesNothing) {
  EXPECT_EQ(write(0x1801, 1, 0x80000285u), 0u);
  EXPECT_EQ(write(0x1801, 5, 2), 0u);  // event timer 2 ms
  EXPECT_EQ(write(0x1801, 1, 0x285), 0u);
  EXPECT_EQ(write(0x1400, 5, 3), 0u);  // RPDO deadline 3 ms
  Counting c;
  const fw::CanFrame rpdo = frame(0x205, {0x0F, 0x00, 0x10, 0x00});
  dualv::test::start_counting();
  for (std::uint64_t k = 0; k < 1000; ++k) {
    const std::uint64_t t = k * 1'000'000;
    if (k % 7 != 0) engine.on_rpdo(rpdo, true, od, c, t);
    od.set(s_sw, static_cast<std::uint32_t>(k % 3));
    engine.transmit_at_sync(od, c, t);
    engine.latch_at_sync(od, c, t);
    engine.on_time(od, c, t + 500'000);
    (void)engine.expired_deadlines(t + 500'000);
    (void)engine.next_due_ns(t);
  }
  EXPECT_EQ(dualv::test::stop_counting(), 0);
  EXPECT_GT(c.sent, 1000);
  EXPECT_GT(c.writes, 1000);
}

}  // namespace
}  // namespace dualv::sim::canopen
