// firmware_if/can_frame.hpp: FD sizes and DLC codes against ISO 11898-1:2015 table 5, and
// which frames a controller can send.
#include "firmware_if/can_frame.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <iterator>

namespace dualv::fw {
namespace {

TEST(CanFrame, FdLengthsAreExactlyTheSixteenCodes) {
  const int valid[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};
  int count = 0;
  for (int n = 0; n <= 255; ++n) {
    const bool expected = std::find(std::begin(valid), std::end(valid), n) != std::end(valid);
    EXPECT_EQ(is_fd_length(static_cast<std::uint8_t>(n)), expected) << n;
    count += is_fd_length(static_cast<std::uint8_t>(n)) ? 1 : 0;
  }
  EXPECT_EQ(count, 16);
}

TEST(CanFrame, DlcCodesByTable) {
  // ISO 11898-1:2015 table 5: DLC 9 = 12, 10 = 16, 11 = 20, 12 = 24, 13 = 32, 14 = 48, 15 = 64.
  EXPECT_EQ(fd_dlc_code(0), 0);
  EXPECT_EQ(fd_dlc_code(8), 8);
  EXPECT_EQ(fd_dlc_code(12), 9);
  EXPECT_EQ(fd_dlc_code(16), 10);
  EXPECT_EQ(fd_dlc_code(20), 11);
  EXPECT_EQ(fd_dlc_code(24), 12);
  EXPECT_EQ(fd_dlc_code(32), 13);
  EXPECT_EQ(fd_dlc_code(48), 14);
  EXPECT_EQ(fd_dlc_code(64), 15);
  EXPECT_EQ(fd_dlc_code(9), 9);  // rounded up to 12 bytes
  EXPECT_EQ(fd_frame_bytes(17), 20);
  EXPECT_EQ(fd_frame_bytes(49), 64);
}

TEST(CanFrame, Validity) {
  CanFrame c;
  c.id = 0x7FF;
  c.dlc = 8;
  EXPECT_TRUE(is_valid(c));
  c.dlc = 9;
  EXPECT_FALSE(is_valid(c));  // classic: 8 bytes at most
  c.dlc = 8;
  c.id = 0x800;
  EXPECT_FALSE(is_valid(c));  // 11-bit id
  c.extended = true;
  EXPECT_TRUE(is_valid(c));
  c.extended = false;
  c.id = 0x100;
  c.brs = true;
  EXPECT_FALSE(is_valid(c));  // BRS without FD

  CanFrame f;
  f.id = 0x200;
  f.fd = true;
  f.brs = true;
  for (std::uint8_t n : std::initializer_list<std::uint8_t>{0, 8, 12, 64}) {
    f.dlc = n;
    EXPECT_TRUE(is_valid(f)) << int{n};
  }
  for (std::uint8_t n : std::initializer_list<std::uint8_t>{9, 13, 63, 65}) {
    f.dlc = n;
    EXPECT_FALSE(is_valid(f)) << int{n};
  }
  f.dlc = 16;
  f.rtr = true;
  EXPECT_FALSE(is_valid(f));  // no remote frames in CAN FD
}

TEST(CanFrame, DataFrameChoosesTheFormat) {
  const CanFrame small = data_frame(0x181, 6, false);
  EXPECT_FALSE(small.fd);
  EXPECT_EQ(small.dlc, 6);
  const CanFrame fd = data_frame(0x181, 6, true);
  EXPECT_TRUE(fd.fd);
  EXPECT_TRUE(fd.brs);
  EXPECT_EQ(fd.dlc, 6);
  const CanFrame big = data_frame(0x200, 14, false);  // does not fit classic: FD, 16 bytes
  EXPECT_TRUE(big.fd);
  EXPECT_EQ(big.dlc, 16);
  EXPECT_TRUE(is_valid(small) && is_valid(fd) && is_valid(big));
}

TEST(CanFrame, EqualityIncludesTheFormat) {
  CanFrame a = data_frame(0x181, 6, false);
  CanFrame b = data_frame(0x181, 6, true);
  EXPECT_NE(a, b);
  b.fd = false;
  b.brs = false;
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace dualv::fw
