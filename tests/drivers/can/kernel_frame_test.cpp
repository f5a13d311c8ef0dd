// fw::CanFrame <-> the kernel's frame (drivers/can/kernel_frame.hpp), checked byte by byte
// against the layout of linux/can.h (can_id u32, len u8, flags u8, 2 reserved, data) and the
// sizes the kernel accepts: CAN_MTU = 16 for a classic frame, CANFD_MTU = 72 for an FD frame.
#include "drivers/can/kernel_frame.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstring>

namespace dualv::drivers {
namespace {

std::array<unsigned char, 72> bytes_of(const canfd_frame& k) {
  std::array<unsigned char, 72> b{};
  std::memcpy(b.data(), &k, b.size());
  return b;
}

TEST(KernelFrame, MtusAreTheKernelsSizes) {
  EXPECT_EQ(CAN_MTU, 16u);
  EXPECT_EQ(CANFD_MTU, 72u);
}

TEST(KernelFrame, FdFrameWithBrsByHand) {
  fw::CanFrame f;
  f.id = 0x200;
  f.fd = true;
  f.brs = true;
  f.dlc = 16;
  for (int i = 0; i < 16; ++i)
    f.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(i + 1);
  canfd_frame k;
  ASSERT_EQ(to_kernel(f, true, k), 72u);
  const auto b = bytes_of(k);
  // can_id 0x00000200 (little endian on this host), len 16, flags FDF|BRS = 0x05, res 0 0.
  const std::uint32_t id = 0x200;
  EXPECT_EQ(std::memcmp(b.data(), &id, 4), 0);
  EXPECT_EQ(b[4], 16);
  EXPECT_EQ(b[5], 0x05);
  EXPECT_EQ(b[6], 0);
  EXPECT_EQ(b[7], 0);
  for (int i = 0; i < 16; ++i) EXPECT_EQ(b[8u + static_cast<std::size_t>(i)], i + 1);
  for (int i = 16; i < 64; ++i) EXPECT_EQ(b[8u + static_cast<std::size_t>(i)], 0);

  fw::CanFrame back;
  ASSERT_TRUE(from_kernel(k, 72, back));
  EXPECT_EQ(back, f);
}

TEST(KernelFrame, ClassicFrameIsTheFirst16Bytes) {
  fw::CanFrame f;
  f.id = 0x18FF00AA;
  f.extended = true;
  f.dlc = 3;
  f.data[0] = 0xDE;
  f.data[1] = 0xAD;
  f.data[2] = 0xBE;
  canfd_frame k;
  ASSERT_EQ(to_kernel(f, false, k), 16u);
  const auto b = bytes_of(k);
  const std::uint32_t id = 0x18FF00AAu | 0x80000000u;  // CAN_EFF_FLAG
  EXPECT_EQ(std::memcmp(b.data(), &id, 4), 0);
  EXPECT_EQ(b[4], 3);
  EXPECT_EQ(b[5], 0);  // no FD flags: a classic frame
  EXPECT_EQ(b[8], 0xDE);
  EXPECT_EQ(b[10], 0xBE);
  fw::CanFrame back;
  ASSERT_TRUE(from_kernel(k, 16, back));
  EXPECT_EQ(back, f);
  EXPECT_FALSE(back.fd);
  // The same on an FD socket: classic frames still pass as classic (16 bytes).
  EXPECT_EQ(to_kernel(f, true, k), 16u);
}

TEST(KernelFrame, RemoteFrameKeepsItsFlag) {
  fw::CanFrame f;
  f.id = 0x701;
  f.rtr = true;
  canfd_frame k;
  ASSERT_EQ(to_kernel(f, false, k), 16u);
  EXPECT_EQ(k.can_id, 0x701u | 0x40000000u);  // CAN_RTR_FLAG
  fw::CanFrame back;
  ASSERT_TRUE(from_kernel(k, 16, back));
  EXPECT_TRUE(back.rtr);
}

TEST(KernelFrame, RefusesWhatTheSocketCannotSend) {
  canfd_frame k;
  fw::CanFrame fd;
  fd.id = 0x181;
  fd.fd = true;
  fd.dlc = 6;
  EXPECT_EQ(to_kernel(fd, false, k), 0u);  // FD frame on a classic socket
  EXPECT_EQ(to_kernel(fd, true, k), 72u);
  fd.dlc = 13;  // no DLC code means 13 bytes
  EXPECT_EQ(to_kernel(fd, true, k), 0u);
  fw::CanFrame classic;
  classic.dlc = 9;
  EXPECT_EQ(to_kernel(classic, true, k), 0u);
  classic.dlc = 8;
  classic.brs = true;  // BRS only exists in FD frames
  EXPECT_EQ(to_kernel(classic, true, k), 0u);
}

TEST(KernelFrame, ReadOfAnotherSizeIsRefused) {
  canfd_frame k{};
  fw::CanFrame f;
  EXPECT_FALSE(from_kernel(k, 8, f));
  EXPECT_FALSE(from_kernel(k, 0, f));
  EXPECT_FALSE(from_kernel(k, 71, f));
}

TEST(KernelFrame, OverlongLengthFromTheKernelIsClamped) {
  canfd_frame k{};
  k.can_id = 0x123;
  k.len = 200;
  fw::CanFrame f;
  ASSERT_TRUE(from_kernel(k, 16, f));
  EXPECT_EQ(f.dlc, 8);
  ASSERT_TRUE(from_kernel(k, 72, f));
  EXPECT_EQ(f.dlc, 64);
}

}  // namespace
}  // namespace dualv::drivers
