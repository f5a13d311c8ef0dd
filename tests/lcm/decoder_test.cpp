// lcm/harden_decoders.cmake: lcm-gen's string decoder on a hostile length. A command_t is
// laid out (LCM type specification) as: 8-byte fingerprint, utime (int64), sequence (int64),
// kind (int8), program (int32 length incl. NUL, bytes), key_id (likewise), hmac[32]; all
// big-endian. The program length is at byte 8 + 8 + 8 + 1 = 25.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <vector>

#include "dualv_lcm/command_t.hpp"
#include "dualv_lcm/setpoint_t.hpp"

namespace {

constexpr std::size_t kProgramLengthAt = 25;

std::vector<std::uint8_t> encoded_command() {
  dualv_lcm::command_t c{};
  c.utime = 1;
  c.sequence = 2;
  c.kind = dualv_lcm::command_t::KIND_START_PROGRAM;
  c.program = "paper";
  c.key_id = "operator";
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(c.getEncodedSize()));
  EXPECT_EQ(c.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  return buf;
}

void put_be32(std::vector<std::uint8_t>& buf, std::size_t at, std::uint32_t v) {
  buf[at] = static_cast<std::uint8_t>(v >> 24);
  buf[at + 1] = static_cast<std::uint8_t>(v >> 16);
  buf[at + 2] = static_cast<std::uint8_t>(v >> 8);
  buf[at + 3] = static_cast<std::uint8_t>(v);
}

TEST(LcmDecoder, TheLayoutAssumedHereIsLcms) {
  const auto buf = encoded_command();
  // "paper" + NUL = 6, big-endian, then the bytes.
  EXPECT_EQ(buf[kProgramLengthAt + 3], 6);
  EXPECT_EQ(std::memcmp(&buf[kProgramLengthAt + 4], "paper", 6), 0);
  dualv_lcm::command_t back;
  EXPECT_EQ(back.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  EXPECT_EQ(back.program, "paper");
}

// INT32_MIN made lcm-gen's `len - 1` overflow (undefined: UBSan aborts this binary); 0 and -1
// reached std::string::assign with a size of 2^64 - 1 (std::length_error). Each is refused.
TEST(LcmDecoder, NonPositiveStringLengthsAreRefusedWithoutUndefinedBehaviour) {
  for (std::uint32_t len : {0x80000000u, 0xffffffffu, 0u, 0x80000001u}) {
    auto buf = encoded_command();
    put_be32(buf, kProgramLengthAt, len);
    dualv_lcm::command_t c;
    int used = 0;
    EXPECT_NO_THROW(used = c.decode(buf.data(), 0, static_cast<int>(buf.size()))) << len;
    EXPECT_LT(used, 0) << len;
  }
}

TEST(LcmDecoder, SetpointKeyIdLengthIsGuardedToo) {
  dualv_lcm::setpoint_t s{};
  s.key_id = "operator";
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(s.getEncodedSize()));
  ASSERT_EQ(s.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  // Find the key_id length field: the 4 bytes before "operator".
  std::size_t at = 0;
  for (std::size_t i = 4; i + 8 <= buf.size(); ++i)
    if (std::memcmp(&buf[i], "operator", 8) == 0) at = i - 4;
  ASSERT_GT(at, 0u);
  put_be32(buf, at, 0x80000000u);
  dualv_lcm::setpoint_t back;
  EXPECT_LT(back.decode(buf.data(), 0, static_cast<int>(buf.size())), 0);
}

}  // namespace
