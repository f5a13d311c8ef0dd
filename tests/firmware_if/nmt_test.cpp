#include "firmware_if/nmt.hpp"

#include <gtest/gtest.h>

#include "frame_builder.hpp"

namespace dualv::fw {
namespace {

using test::make_frame;

TEST(Nmt, GoldenFrames) {
  // CiA 301 7.2.8.3.1: id 000h, [command specifier, node].
  EXPECT_EQ(*encode_nmt(NmtCommand::kStart, 3), make_frame(0x000, {0x01, 0x03}));
  EXPECT_EQ(*encode_nmt(NmtCommand::kStop, 4), make_frame(0x000, {0x02, 0x04}));
  EXPECT_EQ(*encode_nmt(NmtCommand::kEnterPreOperational, 0), make_frame(0x000, {0x80, 0x00}));
  EXPECT_EQ(*encode_nmt(NmtCommand::kResetNode, 0), make_frame(0x000, {0x81, 0x00}));
  EXPECT_EQ(*encode_nmt(NmtCommand::kResetCommunication, 127), make_frame(0x000, {0x82, 0x7F}));
}

TEST(Nmt, DecodeGolden) {
  const Result<NmtMessage> m = decode_nmt(make_frame(0x000, {0x01, 0x03}));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->command, NmtCommand::kStart);
  EXPECT_EQ(m->node, 3);
  EXPECT_TRUE(addressed_to(*m, 3));
  EXPECT_FALSE(addressed_to(*m, 4));
  const Result<NmtMessage> all = decode_nmt(make_frame(0x000, {0x81, 0x00}));
  ASSERT_TRUE(all.ok());
  EXPECT_TRUE(addressed_to(*all, 1));
  EXPECT_TRUE(addressed_to(*all, 127));
}

TEST(Nmt, RoundTrip) {
  for (NmtCommand c : {NmtCommand::kStart, NmtCommand::kStop, NmtCommand::kEnterPreOperational,
                       NmtCommand::kResetNode, NmtCommand::kResetCommunication}) {
    for (const std::uint8_t node : std::initializer_list<std::uint8_t>{0, 1, 4, 127}) {
      const Result<CanFrame> f = encode_nmt(c, node);
      ASSERT_TRUE(f.ok());
      const Result<NmtMessage> m = decode_nmt(*f);
      ASSERT_TRUE(m.ok());
      EXPECT_EQ(*m, (NmtMessage{c, node}));
    }
  }
}

TEST(Nmt, Malformed) {
  EXPECT_EQ(encode_nmt(NmtCommand::kStart, 128).error(), Error::kBadNodeId);
  EXPECT_EQ(encode_nmt(static_cast<NmtCommand>(0x03), 1).error(), Error::kBadValue);
  EXPECT_EQ(decode_nmt(make_frame(0x000, {0x01})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_nmt(make_frame(0x000, {0x01, 0x03, 0x00})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_nmt(make_frame(0x000, {})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_nmt(make_frame(0x000, {0x03, 0x01})).error(), Error::kBadValue);
  EXPECT_EQ(decode_nmt(make_frame(0x000, {0x01, 0x80})).error(), Error::kBadNodeId);
  EXPECT_EQ(decode_nmt(make_frame(0x080, {0x01, 0x03})).error(), Error::kWrongFunction);
  EXPECT_EQ(decode_nmt(make_frame(0x001, {0x01, 0x03})).error(), Error::kUnknownCobId);
  CanFrame ext = make_frame(0x000, {0x01, 0x03});
  ext.extended = true;
  EXPECT_EQ(decode_nmt(ext).error(), Error::kExtendedId);
}

}  // namespace
}  // namespace dualv::fw
