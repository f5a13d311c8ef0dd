#include "firmware_if/heartbeat.hpp"

#include <gtest/gtest.h>

#include "frame_builder.hpp"

namespace dualv::fw {
namespace {

using test::make_frame;

TEST(Heartbeat, GoldenFrames) {
  // CiA 301 table 61: 00h boot-up, 04h stopped, 05h operational, 7Fh pre-operational.
  EXPECT_EQ(*encode_heartbeat(3, NmtState::kOperational), make_frame(0x703, {0x05}));
  EXPECT_EQ(*encode_heartbeat(1, NmtState::kBootUp), make_frame(0x701, {0x00}));
  EXPECT_EQ(*encode_heartbeat(4, NmtState::kStopped), make_frame(0x704, {0x04}));
  EXPECT_EQ(*encode_heartbeat(127, NmtState::kPreOperational), make_frame(0x77F, {0x7F}));
  const Result<Heartbeat> h = decode_heartbeat(make_frame(0x702, {0x05}));
  ASSERT_TRUE(h.ok());
  EXPECT_EQ(h->node, 2);
  EXPECT_EQ(h->state, NmtState::kOperational);
}

TEST(Heartbeat, RoundTrip) {
  for (NmtState s :
       {NmtState::kBootUp, NmtState::kStopped, NmtState::kOperational, NmtState::kPreOperational}) {
    for (std::uint8_t node = 1; node <= 127; ++node) {
      const Result<Heartbeat> h = decode_heartbeat(*encode_heartbeat(node, s));
      ASSERT_TRUE(h.ok());
      EXPECT_EQ(*h, (Heartbeat{node, s}));
    }
  }
}

TEST(Heartbeat, Malformed) {
  EXPECT_EQ(encode_heartbeat(0, NmtState::kOperational).error(), Error::kBadNodeId);
  EXPECT_EQ(encode_heartbeat(128, NmtState::kOperational).error(), Error::kBadNodeId);
  EXPECT_EQ(decode_heartbeat(make_frame(0x703, {})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_heartbeat(make_frame(0x703, {0x05, 0x00})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_heartbeat(make_frame(0x703, {0x01})).error(), Error::kBadValue);
  EXPECT_EQ(decode_heartbeat(make_frame(0x703, {0x85})).error(), Error::kBadValue);  // toggle
  EXPECT_EQ(decode_heartbeat(make_frame(0x700, {0x05})).error(), Error::kUnknownCobId);
  EXPECT_EQ(decode_heartbeat(make_frame(0x603, {0x05})).error(), Error::kWrongFunction);
}

TEST(Heartbeat, ConsumerEntry) {
  // 1016h sub n: node in bits 23..16, time (ms) in bits 15..0.
  EXPECT_EQ(consumer_heartbeat_value(0x7F, 100), 0x007F0064u);
  EXPECT_EQ(consumer_heartbeat_value(1, 0xFFFF), 0x0001FFFFu);
  EXPECT_EQ(consumer_heartbeat_node(0x00050032u), 5);
  EXPECT_EQ(consumer_heartbeat_time_ms(0x00050032u), 50);
}

}  // namespace
}  // namespace dualv::fw
