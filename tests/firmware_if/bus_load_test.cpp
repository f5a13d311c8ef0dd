#include "firmware_if/bus_load.hpp"

#include <gtest/gtest.h>

namespace dualv::fw {
namespace {

TEST(BusLoad, FrameBitsFromDesign) {
  // docs/architecture.md: SYNC 55, RPDO (4 B) 95, TPDO (6 B) 115 bits.
  EXPECT_EQ(worst_case_frame_bits(0), 55u);
  EXPECT_EQ(worst_case_frame_bits(4), 95u);
  EXPECT_EQ(worst_case_frame_bits(6), 115u);
  // 47 + 8n + floor((34 + 8n - 1) / 4), by hand: n=1 65, n=2 75, n=8 135.
  EXPECT_EQ(worst_case_frame_bits(1), 65u);
  EXPECT_EQ(worst_case_frame_bits(2), 75u);
  EXPECT_EQ(worst_case_frame_bits(8), 135u);
  EXPECT_EQ(worst_case_frame_bits(9), 135u);  // classic CAN carries at most 8
  // Extended: 67 + 8n + floor((54 + 8n - 1) / 4): n=0 80, n=8 160.
  EXPECT_EQ(worst_case_extended_frame_bits(0), 80u);
  EXPECT_EQ(worst_case_extended_frame_bits(8), 160u);
}

TEST(BusLoad, CycleBitsFromDesign) {
  // docs/architecture.md: 55 + 4*95 + 4*115 = 895; broadcast 55 + 135 + 4*115 = 650.
  EXPECT_EQ(cycle_bits(4, RpdoLayoutKind::kPerDrive), 895u);
  EXPECT_EQ(cycle_bits(4, RpdoLayoutKind::kBroadcast), 650u);
  // Other sizes, by hand: 1 drive 55 + 95 + 115; broadcast of 2 (one 4-byte frame):
  // 55 + 95 + 2*115;
  // 8 drives broadcast: two 8-byte frames, 55 + 2*135 + 8*115.
  EXPECT_EQ(cycle_bits(1, RpdoLayoutKind::kPerDrive), 265u);
  EXPECT_EQ(cycle_bits(2, RpdoLayoutKind::kBroadcast), 380u);
  EXPECT_EQ(cycle_bits(8, RpdoLayoutKind::kBroadcast), 1245u);
  // SYNC with a counter byte: 65 instead of 55.
  EXPECT_EQ(cycle_bits(4, RpdoLayoutKind::kPerDrive, 1), 905u);
}

TEST(BusLoad, RatesAndLoadFromDesign) {
  // 0.895 ms per cycle at 1 Mbit/s: about 1.1 kHz max, ~90 % at 1 kHz.
  EXPECT_NEAR(max_cycle_rate_hz(895, 1'000'000), 1117.318, 1e-3);
  EXPECT_NEAR(bus_load(895, 1000.0, 1'000'000), 0.895, 1e-12);
  // Broadcast: 1.54 kHz possible, 65 % at 1 kHz.
  EXPECT_NEAR(max_cycle_rate_hz(650, 1'000'000), 1538.462, 1e-3);
  EXPECT_NEAR(bus_load(650, 1000.0, 1'000'000), 0.65, 1e-12);
  EXPECT_EQ(max_cycle_rate_hz(0, 1'000'000), 0.0);
  EXPECT_EQ(bus_load(895, 1000.0, 0), 0.0);
}

TEST(BusLoad, Report) {
  const BusLoadReport ok = bus_load_report(4, RpdoLayoutKind::kPerDrive, 1000.0, 1'000'000);
  EXPECT_EQ(ok.bits_per_cycle, 895u);
  EXPECT_TRUE(ok.fits);
  const BusLoadReport over = bus_load_report(4, RpdoLayoutKind::kPerDrive, 1200.0, 1'000'000);
  EXPECT_FALSE(over.fits);  // 1.074 > 1
  EXPECT_NEAR(over.load, 1.074, 1e-9);
  EXPECT_TRUE(bus_load_report(4, RpdoLayoutKind::kBroadcast, 1200.0, 1'000'000).fits);  // 0.78
  // A margin: 80 % allowed refuses the per-drive 1 kHz layout and accepts broadcast.
  EXPECT_FALSE(bus_load_report(4, RpdoLayoutKind::kPerDrive, 1000.0, 1'000'000, 0.8).fits);
  EXPECT_TRUE(bus_load_report(4, RpdoLayoutKind::kBroadcast, 1000.0, 1'000'000, 0.8).fits);
  // 500 kbit/s: the per-drive layout tops out at 558.66 Hz.
  EXPECT_NEAR(bus_load_report(4, RpdoLayoutKind::kPerDrive, 500.0, 500'000).max_rate_hz, 558.659,
              1e-3);
  EXPECT_FALSE(bus_load_report(4, RpdoLayoutKind::kPerDrive, 1.0, 0).fits);
}

}  // namespace
}  // namespace dualv::fw
