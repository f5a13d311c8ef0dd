#include "firmware_if/byte_order.hpp"

#include <gtest/gtest.h>

#include <array>

namespace dualv::fw {
namespace {

TEST(ByteOrder, LittleEndianGolden) {
  std::array<std::uint8_t, 4> b{};
  put_u32_le(b.data(), 0x12345678u);
  EXPECT_EQ(b, (std::array<std::uint8_t, 4>{0x78, 0x56, 0x34, 0x12}));
  put_u16_le(b.data(), 0xBEEF);
  EXPECT_EQ(b[0], 0xEF);
  EXPECT_EQ(b[1], 0xBE);
  const std::uint8_t w[] = {0x01, 0x02, 0x03, 0x04};
  EXPECT_EQ(get_u16_le(w), 0x0201);
  EXPECT_EQ(get_u32_le(w), 0x04030201u);
  EXPECT_EQ(get_uint_le(w, 3), 0x030201u);
  EXPECT_EQ(get_uint_le(w, 0), 0u);
  EXPECT_EQ(as_i16(0xFFFF), -1);
  EXPECT_EQ(as_i32(0x80000000u), -2147483647 - 1);
}

}  // namespace
}  // namespace dualv::fw
