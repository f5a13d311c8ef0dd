#include "firmware_if/sync.hpp"

#include <gtest/gtest.h>

#include "frame_builder.hpp"

namespace dualv::fw {
namespace {

using test::make_frame;

TEST(Sync, GoldenFrames) {
  EXPECT_EQ(*encode_sync(), make_frame(0x080, {}));
  EXPECT_EQ(*encode_sync(1), make_frame(0x080, {0x01}));
  EXPECT_EQ(*encode_sync(240), make_frame(0x080, {0xF0}));
  EXPECT_EQ(decode_sync(make_frame(0x080, {}))->counter, 0);
  EXPECT_EQ(decode_sync(make_frame(0x080, {0x07}))->counter, 7);
}

TEST(Sync, RoundTrip) {
  for (int c = 0; c <= 240; ++c) {
    const Result<CanFrame> f = encode_sync(static_cast<std::uint8_t>(c));
    ASSERT_TRUE(f.ok());
    EXPECT_EQ(decode_sync(*f)->counter, c);
  }
}

TEST(Sync, Malformed) {
  EXPECT_EQ(encode_sync(241).error(), Error::kBadValue);
  EXPECT_EQ(decode_sync(make_frame(0x080, {0x01, 0x00})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_sync(make_frame(0x080, {0x00})).error(), Error::kBadValue);
  EXPECT_EQ(decode_sync(make_frame(0x080, {0xF1})).error(), Error::kBadValue);
  // 081h is node 1's EMCY, not SYNC.
  EXPECT_EQ(decode_sync(make_frame(0x081, {})).error(), Error::kWrongFunction);
  CanFrame rtr = make_frame(0x080, {});
  rtr.rtr = true;
  EXPECT_EQ(decode_sync(rtr).error(), Error::kRemoteFrame);
}

TEST(Sync, CounterSequence) {
  EXPECT_EQ(next_sync_counter(0, 0), 0);   // no counter configured
  EXPECT_EQ(next_sync_counter(5, 1), 0);   // 1 is not a valid overflow value
  EXPECT_EQ(next_sync_counter(0, 10), 1);  // first counted SYNC
  EXPECT_EQ(next_sync_counter(1, 10), 2);
  EXPECT_EQ(next_sync_counter(9, 10), 10);
  EXPECT_EQ(next_sync_counter(10, 10), 1);  // wraps after the overflow value
  EXPECT_EQ(next_sync_counter(240, 240), 1);
}

}  // namespace
}  // namespace dualv::fw
