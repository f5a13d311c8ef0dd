#include "drivers/can/in_process_bus.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "tests/support/allocation_counter.hpp"

namespace dualv::drivers {
namespace {

fw::CanFrame make_frame(std::uint32_t id, std::uint8_t tag, std::uint8_t dlc = 2) {
  fw::CanFrame f;
  f.id = id;
  f.dlc = dlc;
  for (std::uint8_t i = 0; i < dlc; ++i) {
    f.data[i] = static_cast<std::uint8_t>(tag + i);
  }
  return f;
}

// Everything pending on an endpoint, in arrival order.
std::vector<fw::CanFrame> drain(CanBus& bus) {
  std::vector<fw::CanFrame> out;
  fw::CanFrame f;
  while (bus.receive(f) == BusStatus::kOk) {
    out.push_back(f);
  }
  return out;
}

std::vector<std::uint8_t> tags(const std::vector<fw::CanFrame>& frames) {
  std::vector<std::uint8_t> out;
  for (const auto& f : frames) {
    out.push_back(f.data[0]);
  }
  return out;
}

TEST(InProcessBus, BroadcastsToEveryOtherEndpointButNotTheSender) {
  InProcessHub hub(3);
  auto& a = hub.endpoint(0);
  auto& b = hub.endpoint(1);
  auto& c = hub.endpoint(2);
  hub.set_time_ns(1'000);
  const fw::CanFrame sent = make_frame(0x181, 7, 6);
  ASSERT_EQ(a.send(sent), BusStatus::kOk);

  fw::CanFrame got;
  EXPECT_EQ(a.receive(got), BusStatus::kWouldBlock);  // no echo to the sender
  ASSERT_EQ(b.receive(got), BusStatus::kOk);
  EXPECT_EQ(got, sent);
  EXPECT_EQ(got.timestamp_ns, 1'000u);
  ASSERT_EQ(c.receive(got), BusStatus::kOk);
  EXPECT_EQ(got, sent);
  EXPECT_EQ(b.receive(got), BusStatus::kWouldBlock);

  EXPECT_EQ(a.counters().tx_frames, 1u);
  EXPECT_EQ(b.counters().rx_frames, 1u);
  EXPECT_EQ(c.counters().rx_frames, 1u);
  EXPECT_EQ(hub.stats().delivered, 1u);
}

TEST(InProcessBus, KeepsOrderAndFieldsOfExtendedAndRemoteFrames) {
  InProcessHub hub(2);
  fw::CanFrame ext = make_frame(0x1ABCDEF0, 1, 8);
  ext.extended = true;
  fw::CanFrame rtr;
  rtr.id = 0x701;
  rtr.rtr = true;
  rtr.dlc = 1;
  ASSERT_EQ(hub.endpoint(0).send(ext), BusStatus::kOk);
  ASSERT_EQ(hub.endpoint(0).send(rtr), BusStatus::kOk);
  const auto got = drain(hub.endpoint(1));
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0], ext);
  EXPECT_EQ(got[1], rtr);
}

TEST(InProcessBus, TimestampsComeFromTheInjectedClock) {
  InProcessHub hub(2);
  hub.set_time_ns(5'000'000);
  ASSERT_EQ(hub.endpoint(0).send(make_frame(0x80, 0, 0)), BusStatus::kOk);
  hub.advance_ns(1'000'000);
  ASSERT_EQ(hub.endpoint(0).send(make_frame(0x80, 0, 0)), BusStatus::kOk);
  const auto got = drain(hub.endpoint(1));
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].timestamp_ns, 5'000'000u);
  EXPECT_EQ(got[1].timestamp_ns, 6'000'000u);
  EXPECT_EQ(hub.now_ns(), 6'000'000u);
}

TEST(InProcessBus, FullReceiveRingDropsNewestAndCountsOverruns) {
  InProcessHub hub(2, /*queue_capacity=*/3);
  for (std::uint8_t i = 0; i < 5; ++i) {
    ASSERT_EQ(hub.endpoint(0).send(make_frame(0x200, i)), BusStatus::kOk);
  }
  EXPECT_EQ(hub.endpoint(1).pending(), 3u);
  EXPECT_EQ(hub.endpoint(1).counters().rx_overruns, 2u);
  EXPECT_EQ(tags(drain(hub.endpoint(1))), (std::vector<std::uint8_t>{0, 1, 2}));
  // The ring wraps around correctly after being emptied.
  for (std::uint8_t i = 10; i < 13; ++i) {
    ASSERT_EQ(hub.endpoint(0).send(make_frame(0x200, i)), BusStatus::kOk);
  }
  EXPECT_EQ(tags(drain(hub.endpoint(1))), (std::vector<std::uint8_t>{10, 11, 12}));
}

TEST(InProcessBus, FailNextSendsReturnsWouldBlockAndCounts) {
  InProcessHub hub(2);
  auto& a = hub.endpoint(0);
  a.fail_next_sends(2);
  EXPECT_EQ(a.send(make_frame(0x201, 1)), BusStatus::kWouldBlock);
  EXPECT_EQ(a.send(make_frame(0x201, 2)), BusStatus::kWouldBlock);
  EXPECT_EQ(a.send(make_frame(0x201, 3)), BusStatus::kOk);
  EXPECT_EQ(a.counters().tx_dropped, 2u);
  EXPECT_EQ(a.counters().tx_frames, 1u);
  EXPECT_EQ(tags(drain(hub.endpoint(1))), (std::vector<std::uint8_t>{3}));
}

// CanBus's batch calls (one syscall per batch on SocketCAN, tests/hil/socketcan_hil_test.cpp)
// as every backend inherits them: in order, stopping at the first refusal.
TEST(InProcessBus, SendManyStopsAtTheFirstRefusalAndReceiveManyTakesInOrder) {
  InProcessHub hub(2);
  CanBus& a = hub.endpoint(0);
  CanBus& b = hub.endpoint(1);
  const std::vector<fw::CanFrame> batch = {make_frame(0x080, 1, 0), make_frame(0x201, 2),
                                           make_frame(0x202, 3), make_frame(0x203, 4)};
  BusStatus s = BusStatus::kIoError;
  EXPECT_EQ(a.send_many(batch, s), 4u);
  EXPECT_EQ(s, BusStatus::kOk);
  hub.endpoint(0).fail_next_sends(1);
  EXPECT_EQ(a.send_many(std::span(batch).subspan(1), s), 0u);
  EXPECT_EQ(s, BusStatus::kWouldBlock);
  std::vector<fw::CanFrame> got(3);
  EXPECT_EQ(b.receive_many(got, s), 3u);
  EXPECT_EQ(s, BusStatus::kOk) << "the span is full: more may be pending";
  EXPECT_EQ(got[0].id, 0x080u);
  EXPECT_EQ(got[2], batch[2]);
  EXPECT_EQ(b.receive_many(got, s), 1u);
  EXPECT_EQ(s, BusStatus::kWouldBlock);
  EXPECT_EQ(got[0], batch[3]);
}

TEST(InProcessBus, DropNextLosesFramesSilentlyForTheSender) {
  InProcessHub hub(3);
  auto& a = hub.endpoint(0);
  a.drop_next(2);
  for (std::uint8_t i = 0; i < 4; ++i) {
    EXPECT_EQ(a.send(make_frame(0x201, i)), BusStatus::kOk);
  }
  EXPECT_EQ(a.counters().tx_frames, 4u);
  EXPECT_EQ(a.counters().tx_dropped, 0u);
  EXPECT_EQ(hub.stats().dropped, 2u);
  EXPECT_EQ(tags(drain(hub.endpoint(1))), (std::vector<std::uint8_t>{2, 3}));
  EXPECT_EQ(tags(drain(hub.endpoint(2))), (std::vector<std::uint8_t>{2, 3}));
}

TEST(InProcessBus, InjectionIsPerSender) {
  InProcessHub hub(2);
  hub.endpoint(0).drop_next(1);
  ASSERT_EQ(hub.endpoint(1).send(make_frame(0x181, 9)), BusStatus::kOk);
  EXPECT_EQ(tags(drain(hub.endpoint(0))), (std::vector<std::uint8_t>{9}));
  ASSERT_EQ(hub.endpoint(0).send(make_frame(0x201, 1)), BusStatus::kOk);
  EXPECT_TRUE(drain(hub.endpoint(1)).empty());
}

TEST(InProcessBus, CorruptNextXorsTheDataBytes) {
  InProcessHub hub(2);
  auto& a = hub.endpoint(0);
  a.corrupt_next(1, 0x0F);
  const fw::CanFrame original = make_frame(0x201, 0x10, 3);  // 10 11 12
  ASSERT_EQ(a.send(original), BusStatus::kOk);
  ASSERT_EQ(a.send(original), BusStatus::kOk);
  const auto got = drain(hub.endpoint(1));
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].id, original.id);
  EXPECT_EQ(got[0].dlc, 3);
  EXPECT_EQ(got[0].data[0], 0x1F);
  EXPECT_EQ(got[0].data[1], 0x1E);
  EXPECT_EQ(got[0].data[2], 0x1D);
  EXPECT_EQ(got[0].data[3], 0x00);  // bytes past the DLC stay untouched
  EXPECT_EQ(got[1], original);      // only the next n frames
  EXPECT_EQ(hub.stats().corrupted, 1u);
}

TEST(InProcessBus, DelayNextReordersByKFrames) {
  InProcessHub hub(2);
  auto& a = hub.endpoint(0);
  a.delay_next(1, 2);
  hub.set_time_ns(100);
  ASSERT_EQ(a.send(make_frame(0x201, 0)), BusStatus::kOk);  // held back
  EXPECT_EQ(hub.delayed_count(), 1u);
  EXPECT_TRUE(drain(hub.endpoint(1)).empty());
  hub.set_time_ns(200);
  ASSERT_EQ(a.send(make_frame(0x201, 1)), BusStatus::kOk);
  EXPECT_EQ(tags(drain(hub.endpoint(1))), (std::vector<std::uint8_t>{1}));
  hub.set_time_ns(300);
  ASSERT_EQ(a.send(make_frame(0x201, 2)), BusStatus::kOk);
  const auto got = drain(hub.endpoint(1));
  // Frame 0 arrives right after the second further frame, stamped when it arrives.
  EXPECT_EQ(tags(got), (std::vector<std::uint8_t>{2, 0}));
  EXPECT_EQ(got[1].timestamp_ns, 300u);
  EXPECT_EQ(hub.delayed_count(), 0u);
  EXPECT_EQ(hub.stats().delayed, 1u);
}

TEST(InProcessBus, DelayCountsFramesFromAnyEndpoint) {
  InProcessHub hub(3);
  hub.endpoint(0).delay_next(2, 1);
  ASSERT_EQ(hub.endpoint(0).send(make_frame(0x201, 0)), BusStatus::kOk);
  ASSERT_EQ(hub.endpoint(0).send(make_frame(0x201, 1)), BusStatus::kOk);
  EXPECT_EQ(hub.delayed_count(), 2u);
  ASSERT_EQ(hub.endpoint(1).send(make_frame(0x181, 9)), BusStatus::kOk);
  EXPECT_EQ(tags(drain(hub.endpoint(2))), (std::vector<std::uint8_t>{9, 0, 1}));
  EXPECT_EQ(tags(drain(hub.endpoint(1))), (std::vector<std::uint8_t>{0, 1}));
}

TEST(InProcessBus, ReleaseDelayedDeliversInSendOrder) {
  InProcessHub hub(2);
  hub.endpoint(0).delay_next(3, 100);
  for (std::uint8_t i = 0; i < 3; ++i) {
    ASSERT_EQ(hub.endpoint(0).send(make_frame(0x201, i)), BusStatus::kOk);
  }
  hub.release_delayed();
  EXPECT_EQ(tags(drain(hub.endpoint(1))), (std::vector<std::uint8_t>{0, 1, 2}));
}

TEST(InProcessBus, DelayBeyondCapacityIsDeliveredAtOnceAndCounted) {
  InProcessHub hub(2, 16, /*delay_capacity=*/1);
  hub.endpoint(0).delay_next(2, 5);
  ASSERT_EQ(hub.endpoint(0).send(make_frame(0x201, 0)), BusStatus::kOk);
  ASSERT_EQ(hub.endpoint(0).send(make_frame(0x201, 1)), BusStatus::kOk);
  EXPECT_EQ(hub.stats().delay_overflows, 1u);
  EXPECT_EQ(tags(drain(hub.endpoint(1))), (std::vector<std::uint8_t>{1}));
}

TEST(InProcessBus, BusOffLatchesUntilRestartAndDiscardsStaleFrames) {
  InProcessHub hub(2);
  auto& a = hub.endpoint(0);
  auto& b = hub.endpoint(1);
  ASSERT_EQ(b.send(make_frame(0x181, 1)), BusStatus::kOk);  // queued at a before the fault
  a.delay_next(1, 10);
  ASSERT_EQ(a.send(make_frame(0x201, 2)), BusStatus::kOk);  // a's frame still in flight

  a.force_bus_off();
  a.force_bus_off();  // one event per transition
  EXPECT_EQ(a.state(), BusStatus::kBusOff);
  EXPECT_EQ(a.counters().bus_off_events, 1u);
  fw::CanFrame f;
  EXPECT_EQ(a.send(make_frame(0x201, 3)), BusStatus::kBusOff);
  EXPECT_EQ(a.receive(f), BusStatus::kBusOff);
  EXPECT_EQ(a.counters().tx_dropped, 1u);
  // A bus-off controller receives nothing.
  ASSERT_EQ(b.send(make_frame(0x181, 4)), BusStatus::kOk);
  EXPECT_EQ(a.state(), BusStatus::kBusOff);  // still latched after traffic

  EXPECT_EQ(a.restart(), BusStatus::kOk);
  EXPECT_EQ(a.state(), BusStatus::kOk);
  EXPECT_EQ(a.counters().restarts, 1u);
  EXPECT_EQ(a.receive(f), BusStatus::kWouldBlock);  // frame 1 was stale: discarded
  EXPECT_EQ(hub.stats().discarded_delayed, 1u);     // frame 2 never arrives late
  hub.release_delayed();
  EXPECT_TRUE(drain(b).empty());

  ASSERT_EQ(a.send(make_frame(0x201, 5)), BusStatus::kOk);
  EXPECT_EQ(tags(drain(b)), (std::vector<std::uint8_t>{5}));
  ASSERT_EQ(b.send(make_frame(0x181, 6)), BusStatus::kOk);
  EXPECT_EQ(tags(drain(a)), (std::vector<std::uint8_t>{6}));
}

TEST(InProcessBus, RestartCanBeRefusedToModelAControllerThatStaysOff) {
  InProcessHub hub(2);
  auto& a = hub.endpoint(0);
  a.force_bus_off(/*refuse_restart=*/true);
  EXPECT_EQ(a.restart(), BusStatus::kBusOff);
  EXPECT_EQ(a.state(), BusStatus::kBusOff);
  a.force_bus_off(false);
  EXPECT_EQ(a.restart(), BusStatus::kOk);
  EXPECT_EQ(a.counters().bus_off_events, 1u);
}

TEST(InProcessBus, ErrorPassiveIsReportedWhileFramesStillPass) {
  InProcessHub hub(2);
  auto& a = hub.endpoint(0);
  a.force_error_passive(true);
  EXPECT_EQ(a.state(), BusStatus::kErrorPassive);
  EXPECT_EQ(a.counters().error_passive_events, 1u);
  EXPECT_EQ(a.send(make_frame(0x201, 1)), BusStatus::kOk);
  EXPECT_EQ(tags(drain(hub.endpoint(1))), (std::vector<std::uint8_t>{1}));
  a.force_error_passive(false);
  EXPECT_EQ(a.state(), BusStatus::kOk);
}

TEST(InProcessBus, FailuresApplyInDocumentedOrder) {
  // fail_next_sends is checked before the frame is accepted, so it does not consume a
  // drop; bus-off comes first of all.
  InProcessHub hub(2);
  auto& a = hub.endpoint(0);
  a.fail_next_sends(1);
  a.drop_next(1);
  EXPECT_EQ(a.send(make_frame(0x201, 1)), BusStatus::kWouldBlock);
  EXPECT_EQ(a.send(make_frame(0x201, 2)), BusStatus::kOk);  // dropped
  EXPECT_EQ(a.send(make_frame(0x201, 3)), BusStatus::kOk);
  EXPECT_EQ(tags(drain(hub.endpoint(1))), (std::vector<std::uint8_t>{3}));
  a.fail_next_sends(1);
  a.force_bus_off();
  EXPECT_EQ(a.send(make_frame(0x201, 4)), BusStatus::kBusOff);
  ASSERT_EQ(a.restart(), BusStatus::kOk);
  EXPECT_EQ(a.send(make_frame(0x201, 5)), BusStatus::kWouldBlock);  // still armed
}

TEST(InProcessBus, SameScriptGivesTheSameTrace) {
  auto run = [] {
    InProcessHub hub(3, 8);
    hub.endpoint(0).delay_next(3, 2);
    hub.endpoint(1).corrupt_next(2);
    hub.endpoint(2).drop_next(1);
    std::vector<fw::CanFrame> trace;
    for (std::uint8_t i = 0; i < 30; ++i) {
      hub.advance_ns(1000);
      (void)hub.endpoint(i % 3).send(make_frame(0x100u + i % 3, i));
      for (const auto& f : drain(hub.endpoint((i + 1) % 3))) {
        trace.push_back(f);
      }
    }
    return trace;
  };
  const auto a = run();
  const auto b = run();
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i], b[i]);
    EXPECT_EQ(a[i].timestamp_ns, b[i].timestamp_ns);
  }
}

TEST(InProcessBus, CyclesAllocateNothing) {
  InProcessHub hub(5, 16, 4);
  auto& master = hub.endpoint(0);
  master.delay_next(100, 3);
  master.corrupt_next(50);
  hub.endpoint(1).drop_next(20);
  hub.endpoint(2).fail_next_sends(10);
  fw::CanFrame f;
  const long before = dualv::test::allocation_count();
  for (std::uint32_t cycle = 0; cycle < 2000; ++cycle) {
    hub.advance_ns(1'000'000);
    (void)master.send(make_frame(0x080, 0, 0));
    for (std::uint32_t node = 1; node < 5; ++node) {
      (void)master.send(make_frame(0x200 + node, static_cast<std::uint8_t>(cycle), 4));
      (void)hub.endpoint(node).send(make_frame(0x180 + node, static_cast<std::uint8_t>(cycle), 6));
      while (hub.endpoint(node).receive(f) == BusStatus::kOk) {
      }
    }
    while (master.receive(f) == BusStatus::kOk) {
    }
    if (cycle % 500 == 499) {
      hub.endpoint(3).force_bus_off();
      (void)hub.endpoint(3).restart();
      hub.release_delayed();
    }
  }
  EXPECT_EQ(dualv::test::allocation_count(), before);
  EXPECT_GT(hub.stats().delivered, 10'000u);
}

TEST(InProcessBus, SetUpErrorsAreReported) {
  EXPECT_THROW(InProcessHub(1), std::invalid_argument);
  EXPECT_THROW(InProcessHub(2, 0), std::invalid_argument);
  InProcessHub hub(2);
  EXPECT_THROW((void)hub.endpoint(2), std::out_of_range);
  EXPECT_EQ(hub.endpoint(1).index(), 1u);
}

TEST(InProcessBus, UsableThroughTheCanBusInterface) {
  InProcessHub hub(2);
  CanBus& a = hub.endpoint(0);
  CanBus& b = hub.endpoint(1);
  ASSERT_EQ(a.send(make_frame(0x80, 0, 0)), BusStatus::kOk);
  fw::CanFrame f;
  EXPECT_EQ(b.receive(f), BusStatus::kOk);
  EXPECT_EQ(f.id, 0x80u);
  EXPECT_STREQ(to_string(BusStatus::kWouldBlock), "would block");
  EXPECT_STREQ(to_string(BusStatus::kBusOff), "bus-off");
}

}  // namespace
}  // namespace dualv::drivers

namespace dualv::drivers {
namespace {

TEST(InProcessBusFd, CarriesFdFramesWhole) {
  InProcessHub hub(2);
  fw::CanFrame f = fw::data_frame(0x200, 64, true);
  for (std::size_t i = 0; i < 64; ++i) f.data[i] = static_cast<std::uint8_t>(0xA0 ^ i);
  ASSERT_EQ(hub.endpoint(0).send(f), BusStatus::kOk);
  const std::vector<fw::CanFrame> got = drain(hub.endpoint(1));
  ASSERT_EQ(got.size(), 1u);
  EXPECT_TRUE(got[0].fd);
  EXPECT_TRUE(got[0].brs);
  EXPECT_EQ(got[0].dlc, 64);
  EXPECT_EQ(got[0].data[63], 0xA0 ^ 63);
  EXPECT_EQ(got[0], f);
}

TEST(InProcessBusFd, RefusesFramesNoControllerSends) {
  InProcessHub hub(2);
  fw::CanFrame classic9 = make_frame(0x181, 1, 8);
  classic9.dlc = 9;
  fw::CanFrame fd13 = fw::data_frame(0x181, 12, true);
  fd13.dlc = 13;
  EXPECT_EQ(hub.endpoint(0).send(classic9), BusStatus::kIoError);
  EXPECT_EQ(hub.endpoint(0).send(fd13), BusStatus::kIoError);
  EXPECT_EQ(hub.endpoint(0).counters().tx_dropped, 2u);
  EXPECT_TRUE(drain(hub.endpoint(1)).empty());
}

}  // namespace
}  // namespace dualv::drivers
