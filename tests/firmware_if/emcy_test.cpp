#include "firmware_if/emcy.hpp"

#include <gtest/gtest.h>

#include <string>

#include "frame_builder.hpp"

namespace dualv::fw {
namespace {

using test::make_frame;

TEST(Emcy, GoldenFrame) {
  // Node 2, DC link over-voltage 3210h, error register voltage (bit 2) + generic (bit 0),
  // manufacturer bytes 11..55: [10 32 05 11 22 33 44 55] on 082h.
  Emcy e;
  e.node = 2;
  e.error_code = 0x3210;
  e.error_register = 0x05;
  e.manufacturer = {0x11, 0x22, 0x33, 0x44, 0x55};
  EXPECT_EQ(*encode_emcy(e), make_frame(0x082, {0x10, 0x32, 0x05, 0x11, 0x22, 0x33, 0x44, 0x55}));
  const Result<Emcy> d =
      decode_emcy(make_frame(0x084, {0x30, 0x81, 0x11, 0x00, 0x00, 0x00, 0x00, 0x00}));
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->node, 4);
  EXPECT_EQ(d->error_code, 0x8130);  // heartbeat error
  EXPECT_EQ(d->error_register, 0x11);
  EXPECT_FALSE(d->is_reset());
}

TEST(Emcy, ResetClears) {
  const Result<Emcy> d =
      decode_emcy(make_frame(0x081, {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
  ASSERT_TRUE(d.ok());
  EXPECT_TRUE(d->is_reset());
  EXPECT_EQ(std::string(emcy_text(0x0000)), "error reset or no error");
}

TEST(Emcy, RoundTrip) {
  for (const std::uint16_t code : std::initializer_list<std::uint16_t>{
           0x0000, 0x1000, 0x2310, 0x5000, 0x8250, 0xFF00, 0xFFFF}) {
    Emcy e;
    e.node = 127;
    e.error_code = code;
    e.error_register = 0x81;
    e.manufacturer = {1, 2, 3, 4, 5};
    const Result<Emcy> d = decode_emcy(*encode_emcy(e));
    ASSERT_TRUE(d.ok());
    EXPECT_EQ(*d, e);
  }
}

TEST(Emcy, Malformed) {
  Emcy e;
  e.node = 0;
  EXPECT_EQ(encode_emcy(e).error(), Error::kBadNodeId);
  EXPECT_EQ(decode_emcy(make_frame(0x081, {0x10, 0x32, 0x05})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_emcy(make_frame(0x081, {})).error(), Error::kWrongDlc);
  // 080h is SYNC, not an EMCY of node 0.
  EXPECT_EQ(decode_emcy(make_frame(0x080, {0, 0, 0, 0, 0, 0, 0, 0})).error(),
            Error::kWrongFunction);
  EXPECT_EQ(decode_emcy(make_frame(0x181, {0, 0, 0, 0, 0, 0, 0, 0})).error(),
            Error::kWrongFunction);
}

TEST(Emcy, Texts) {
  EXPECT_EQ(std::string(emcy_text(0x3210)), "DC link over-voltage");
  EXPECT_EQ(std::string(emcy_text(0x8130)), "life guard or heartbeat error");
  EXPECT_EQ(std::string(emcy_text(0x8250)), "RPDO timeout");
  EXPECT_EQ(std::string(emcy_text(0x2310)), "continuous over-current");
  // Unlisted codes fall back to their class.
  EXPECT_EQ(std::string(emcy_text(0x3211)), "voltage inside the device");
  EXPECT_EQ(std::string(emcy_text(0x5123)), "device hardware");
  EXPECT_EQ(std::string(emcy_text(0x0001)), "unknown error code");
}

}  // namespace
}  // namespace dualv::fw
