// The heartbeat consumer part (sim/canopen/heartbeat_consumer.hpp), from CiA 301 7.2.8.3.2.2
// and 7.5.2.19: 1016h sub n = node << 16 | ms (written here by hand: 0x007F0064 = node 127,
// 100 ms); monitoring starts with the first heartbeat; the event at T after the last
// heartbeat (not at T - 1 ns), once; the heartbeat coming back ends it.
#include "sim/canopen/heartbeat_consumer.hpp"

#include <gtest/gtest.h>

namespace dualv::sim::canopen {
namespace {

constexpr std::uint64_t kMs = 1'000'000;

struct Consumer : ::testing::Test {
  ObjectDictionary od;
  HeartbeatConsumer hb;
  void SetUp() override {
    std::array<int, kHeartbeatConsumers> slots{};
    od.add(fw::od::kConsumerHeartbeatCount, 2);
    slots[0] = od.add(fw::od::consumer_heartbeat(1), 0x007F0064u);  // node 127, 100 ms
    slots[1] = od.add(fw::od::consumer_heartbeat(2), 0x00030000u);  // node 3, unused (0 ms)
    hb.attach(slots);
  }
};

TEST_F(Consumer, NotMonitoredBeforeTheFirstHeartbeat) {
  EXPECT_EQ(hb.on_time(od, 10'000 * kMs), 0u);
  EXPECT_EQ(hb.next_due_ns(od), HeartbeatConsumer::kNever);
}

TEST_F(Consumer, LossAtTheConsumerTimeOnceAndBack) {
  EXPECT_EQ(hb.on_heartbeat(od, 127, 50 * kMs), 0u);
  EXPECT_EQ(hb.next_due_ns(od), 150 * kMs);
  EXPECT_EQ(hb.on_time(od, 150 * kMs - 1), 0u);  // T - 1 ns
  EXPECT_EQ(hb.on_time(od, 150 * kMs), 1u);      // T: entry 1 (bit 0)
  EXPECT_TRUE(hb.lost(0));
  EXPECT_TRUE(hb.any_lost());
  EXPECT_EQ(hb.on_time(od, 300 * kMs), 0u);  // once
  EXPECT_EQ(hb.next_due_ns(od), HeartbeatConsumer::kNever);
  EXPECT_EQ(hb.on_heartbeat(od, 127, 310 * kMs), 1u);  // back
  EXPECT_FALSE(hb.any_lost());
  EXPECT_EQ(hb.next_due_ns(od), 410 * kMs);
}

TEST_F(Consumer, OtherNodesAndUnusedEntriesDoNotCount) {
  EXPECT_EQ(hb.on_heartbeat(od, 3, 0), 0u);  // entry 2 has time 0: unused
  EXPECT_EQ(hb.on_heartbeat(od, 126, 0), 0u);
  EXPECT_EQ(hb.on_time(od, 1000 * kMs), 0u);
}

TEST_F(Consumer, ResetStopsMonitoringUntilTheNextHeartbeat) {
  hb.on_heartbeat(od, 127, 0);
  hb.reset();
  EXPECT_EQ(hb.on_time(od, 500 * kMs), 0u);
  hb.on_heartbeat(od, 127, 500 * kMs);
  EXPECT_EQ(hb.on_time(od, 600 * kMs), 1u);
}

}  // namespace
}  // namespace dualv::sim::canopen
