#include "drivers/can/batching_bus.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "drivers/can/in_process_bus.hpp"

namespace dualv::drivers {
namespace {

fw::CanFrame frame_of(std::uint32_t id, std::uint8_t tag) {
  fw::CanFrame f;
  f.id = id;
  f.dlc = 1;
  f.data[0] = tag;
  return f;
}

std::vector<std::uint8_t> tags_received(CanBus& bus) {
  std::vector<std::uint8_t> out;
  fw::CanFrame f;
  while (bus.receive(f) == BusStatus::kOk) out.push_back(f.data[0]);
  return out;
}

TEST(BatchingBus, SendsNothingUntilFlushThenEverythingInOrder) {
  InProcessHub hub(2);
  BatchingBus bus(hub.endpoint(0));
  for (std::uint8_t i = 0; i < 5; ++i) ASSERT_EQ(bus.send(frame_of(0x181, i)), BusStatus::kOk);
  EXPECT_EQ(bus.queued(), 5u);
  EXPECT_TRUE(tags_received(hub.endpoint(1)).empty()) << "held until flush()";
  EXPECT_EQ(bus.flush(), BusStatus::kOk);
  EXPECT_EQ(bus.queued(), 0u);
  EXPECT_EQ(tags_received(hub.endpoint(1)), (std::vector<std::uint8_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(bus.counters().tx_frames, 5u) << "the bus underneath counts";
}

TEST(BatchingBus, ARefusedFrameIsDroppedAndTheRestStillGo) {
  InProcessHub hub(2);
  BatchingBus bus(hub.endpoint(0));
  for (std::uint8_t i = 0; i < 4; ++i) (void)bus.send(frame_of(0x181, i));
  hub.endpoint(0).fail_next_sends(1);
  EXPECT_EQ(bus.flush(), BusStatus::kWouldBlock);
  EXPECT_EQ(tags_received(hub.endpoint(1)), (std::vector<std::uint8_t>{1, 2, 3}));
  EXPECT_EQ(bus.counters().tx_dropped, 1u);
  EXPECT_EQ(bus.flush(), BusStatus::kOk) << "never sent late";
  EXPECT_TRUE(tags_received(hub.endpoint(1)).empty());
}

TEST(BatchingBus, AFullQueueIsFlushedFirst) {
  InProcessHub hub(2, 256);
  BatchingBus bus(hub.endpoint(0));
  for (int i = 0; i < 70; ++i) (void)bus.send(frame_of(0x181, static_cast<std::uint8_t>(i)));
  EXPECT_EQ(tags_received(hub.endpoint(1)).size(), 64u);
  (void)bus.flush();
  EXPECT_EQ(tags_received(hub.endpoint(1)).size(), 6u);
}

TEST(BatchingBus, ReceivesEveryFrameInOrderAcrossBatchesAndLaterArrivals) {
  InProcessHub hub(2, 256);
  BatchingBus bus(hub.endpoint(1));
  for (int i = 0; i < 100; ++i)
    ASSERT_EQ(hub.endpoint(0).send(frame_of(0x201, static_cast<std::uint8_t>(i))), BusStatus::kOk);
  std::vector<std::uint8_t> got = tags_received(bus);
  ASSERT_EQ(got.size(), 100u);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(got[static_cast<std::size_t>(i)], i);
  // Frames that come after a read found the queue empty are read by the next calls.
  ASSERT_EQ(hub.endpoint(0).send(frame_of(0x201, 7)), BusStatus::kOk);
  EXPECT_EQ(tags_received(bus), (std::vector<std::uint8_t>{7}));
  ASSERT_EQ(hub.endpoint(0).send(frame_of(0x201, 8)), BusStatus::kOk);
  ASSERT_EQ(hub.endpoint(0).send(frame_of(0x201, 9)), BusStatus::kOk);
  EXPECT_EQ(tags_received(bus), (std::vector<std::uint8_t>{8, 9}));
  fw::CanFrame f;
  EXPECT_EQ(bus.receive(f), BusStatus::kWouldBlock);
}

TEST(BatchingBus, RestartDropsWhatIsQueued) {
  InProcessHub hub(2);
  BatchingBus bus(hub.endpoint(0));
  (void)bus.send(frame_of(0x181, 1));
  hub.endpoint(0).force_bus_off(false);
  EXPECT_EQ(bus.send(frame_of(0x181, 2)), BusStatus::kBusOff);
  EXPECT_EQ(bus.restart(), BusStatus::kOk);
  EXPECT_EQ(bus.flush(), BusStatus::kOk);
  EXPECT_TRUE(tags_received(hub.endpoint(1)).empty()) << "nothing from before the fault";
}

}  // namespace
}  // namespace dualv::drivers
