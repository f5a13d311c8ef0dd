// Heartbeat consumer timeout at exactly T - 1 / T, the master's heartbeat producer, SYNC
// producer counter, EMCY consumer decode + 0000h clears.
#include <gtest/gtest.h>

#include "drivers/can/in_process_bus.hpp"
#include "drivers/canopen/emcy_consumer.hpp"
#include "drivers/canopen/heartbeat_consumer.hpp"
#include "drivers/canopen/heartbeat_producer.hpp"
#include "drivers/canopen/sync_producer.hpp"
#include "fake_slave.hpp"

namespace dualv::drivers::canopen {
namespace {

constexpr std::uint64_t kMs = 1'000'000;

TEST(HeartbeatConsumer, TimeoutAtExactlyT) {
  HeartbeatConsumer c(3, 150 * kMs);
  EXPECT_EQ(c.check(10'000 * kMs), HeartbeatEvent::kNone);  // not armed: never times out
  EXPECT_EQ(c.on_heartbeat(fw::NmtState::kOperational, 1000 * kMs), HeartbeatEvent::kStateChanged);
  EXPECT_EQ(c.check(1000 * kMs + 150 * kMs - 1), HeartbeatEvent::kNone);
  EXPECT_FALSE(c.timed_out());
  EXPECT_EQ(c.check(1000 * kMs + 150 * kMs), HeartbeatEvent::kTimeout);
  EXPECT_TRUE(c.timed_out());
  EXPECT_EQ(c.check(1000 * kMs + 151 * kMs), HeartbeatEvent::kNone);  // reported once
  EXPECT_EQ(c.timeouts(), 1u);
  EXPECT_EQ(c.on_heartbeat(fw::NmtState::kOperational, 1200 * kMs), HeartbeatEvent::kRecovered);
  EXPECT_FALSE(c.timed_out());
}

TEST(HeartbeatConsumer, ArmedWithoutHeartbeat) {
  HeartbeatConsumer c(3, 150 * kMs);
  c.arm(100 * kMs);
  EXPECT_EQ(c.check(250 * kMs - 1), HeartbeatEvent::kNone);
  EXPECT_EQ(c.check(250 * kMs), HeartbeatEvent::kTimeout);
}

TEST(HeartbeatConsumer, BootUpAndStates) {
  HeartbeatConsumer c(3, 150 * kMs);
  EXPECT_EQ(c.on_heartbeat(fw::NmtState::kBootUp, 0), HeartbeatEvent::kBootUp);
  EXPECT_EQ(c.boot_ups(), 1u);
  EXPECT_EQ(c.on_heartbeat(fw::NmtState::kPreOperational, 1), HeartbeatEvent::kStateChanged);
  EXPECT_EQ(c.on_heartbeat(fw::NmtState::kPreOperational, 2), HeartbeatEvent::kNone);
  EXPECT_EQ(c.state(), fw::NmtState::kPreOperational);
}

TEST(HeartbeatProducer, FirstAtOnceThenEveryPeriod) {
  InProcessHub hub(2);
  HeartbeatProducer p(127, 50 * kMs);
  EXPECT_EQ(p.poll(hub.endpoint(0), 7 * kMs), BusStatus::kOk);
  EXPECT_EQ(p.poll(hub.endpoint(0), 7 * kMs + 50 * kMs - 1), BusStatus::kOk);
  EXPECT_EQ(p.sent(), 1u);
  p.poll(hub.endpoint(0), 57 * kMs);
  EXPECT_EQ(p.sent(), 2u);
  const auto wire = test::drain(hub.endpoint(1));
  ASSERT_EQ(wire.size(), 2u);
  EXPECT_EQ(test::to_text(wire[0]), "77F#05");  // 700h + 127, Operational
}

TEST(HeartbeatProducer, FailedSendRetriedNextPoll) {
  InProcessHub hub(2);
  HeartbeatProducer p(127, 50 * kMs);
  hub.endpoint(0).fail_next_sends(1);
  EXPECT_EQ(p.poll(hub.endpoint(0), 0), BusStatus::kWouldBlock);
  EXPECT_EQ(p.poll(hub.endpoint(0), 1), BusStatus::kOk);
  EXPECT_EQ(p.sent(), 1u);
  EXPECT_EQ(p.failed(), 1u);
}

TEST(SyncProducer, CounterWrapsAndNeverJumpsOnFailedSend) {
  InProcessHub hub(2);
  SyncProducer s(3);
  s.send(hub.endpoint(0));
  hub.endpoint(0).fail_next_sends(1);
  EXPECT_EQ(s.send(hub.endpoint(0)), BusStatus::kWouldBlock);
  s.send(hub.endpoint(0));
  s.send(hub.endpoint(0));
  s.send(hub.endpoint(0));
  const auto wire = test::drain(hub.endpoint(1));
  ASSERT_EQ(wire.size(), 4u);
  EXPECT_EQ(test::to_text(wire[0]), "080#01");
  EXPECT_EQ(test::to_text(wire[1]), "080#02");  // the failed one did not advance the counter
  EXPECT_EQ(test::to_text(wire[2]), "080#03");
  EXPECT_EQ(test::to_text(wire[3]), "080#01");
  SyncProducer plain;
  plain.send(hub.endpoint(0));
  EXPECT_EQ(test::to_text(test::drain(hub.endpoint(1)).at(0)), "080#");
}

TEST(EmcyConsumer, DecodedWithTextAndResetClears) {
  EmcyConsumer c;
  fw::Emcy e;
  e.node = 2;
  e.error_code = fw::emcy::kDeviceOverTemperature;
  e.error_register = fw::error_register::kTemperature;
  EXPECT_TRUE(c.on_emcy(e, 5));
  EXPECT_TRUE(c.active());
  EXPECT_EQ(c.active_code(), 0x4210);
  EXPECT_STRNE(c.last_text(), "none");
  fw::Emcy reset;
  reset.node = 2;
  EXPECT_FALSE(c.on_emcy(reset, 6));  // 0000h clears, is not a new error
  EXPECT_FALSE(c.active());
  EXPECT_EQ(c.active_code(), 0);
  EXPECT_EQ(c.last().error_code, 0x4210);  // history kept for health and logs
  EXPECT_EQ(c.raised(), 1u);
  EXPECT_EQ(c.resets(), 1u);
}

}  // namespace
}  // namespace dualv::drivers::canopen
