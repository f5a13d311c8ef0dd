// The three bus layouts of issue 15 (firmware_if/bus_layout.hpp) against figures computed by
// hand from the frame sizes (docs/architecture.md "Beating the naive bus limit").
#include "firmware_if/bus_layout.hpp"

#include <gtest/gtest.h>

namespace dualv::fw {
namespace {

TEST(BusLayout, PerDriveByHand) {
  // SYNC 55 + 4 x RPDO(4 B) 95 + 4 x TPDO(6 B) 115 = 895 bits = 895 us at 1 Mbit/s.
  const LayoutLoad r = layout_load(BusLayout::kPerDrive, BusParams{}, 1000.0);
  EXPECT_EQ(r.cyclic_bits, (FrameBits{895, 0}));
  EXPECT_NEAR(r.cycle_time_s, 895e-6, 1e-12);
  EXPECT_EQ(r.event_load, 0.0);
  EXPECT_NEAR(r.cyclic_load, 0.895, 1e-9);
  EXPECT_TRUE(r.fits);  // 89.5 % <= 90 %
  EXPECT_NEAR(r.full_rate_hz, 1e6 / 895, 1e-6);
  EXPECT_NEAR(r.max_rate_hz, 0.90e6 / 895, 1e-6);  // 1005.6 Hz
  EXPECT_FALSE(layout_load(BusLayout::kPerDrive, BusParams{}, 1500.0).fits);
}

TEST(BusLayout, BroadcastByHand) {
  // Cyclic: SYNC 55 + torques (8 B) 135 + 4 x position (4 B) 95 = 570 bits.
  // Events: 4 statuswords + 4 controlwords (2 B, 75 bits) each at most once per 10 ms:
  // 8 x 75 us / 10 ms = 6 % of the bus.
  const LayoutLoad r = layout_load(BusLayout::kBroadcast, BusParams{}, 1500.0);
  EXPECT_EQ(r.cyclic_bits, (FrameBits{570, 0}));
  EXPECT_NEAR(r.event_load, 0.06, 1e-12);
  EXPECT_NEAR(r.cyclic_load, 0.855, 1e-9);  // docs/architecture.md: 85.5 % at 1.5 kHz
  EXPECT_NEAR(r.total_load, 0.915, 1e-9);
  EXPECT_TRUE(r.fits);  // the target: 1.5 kHz within 90 % / 95 %
  // The total limit binds: (0.95 - 0.06) / 570 us = 1561.4 Hz (< 0.90 / 570 us = 1578.9 Hz).
  EXPECT_NEAR(r.max_rate_hz, 0.89 / 570e-6, 1e-6);
  EXPECT_NEAR(r.full_rate_hz, 0.94 / 570e-6, 1e-6);
  // A shorter inhibit time costs rate: 2 ms -> 30 % events, (0.95 - 0.30) / 570 us.
  BusParams fast_events;
  fast_events.statusword_inhibit_s = fast_events.controlword_inhibit_s = 0.002;
  const LayoutLoad f = layout_load(BusLayout::kBroadcast, fast_events, 1500.0);
  EXPECT_NEAR(f.event_load, 0.30, 1e-12);
  EXPECT_FALSE(f.fits);
  EXPECT_NEAR(f.max_rate_hz, 0.65 / 570e-6, 1e-6);
}

TEST(BusLayout, BroadcastOtherDriveCounts) {
  // 2 drives: torques in one 4-byte frame: 55 + 95 + 2 x 95 = 340.
  BusParams two;
  two.drives = 2;
  EXPECT_EQ(layout_load(BusLayout::kBroadcast, two, 1000.0).cyclic_bits.nominal, 340u);
  // 6 drives: an 8-byte frame and a 4-byte one: 55 + 135 + 95 + 6 x 95 = 855.
  BusParams six;
  six.drives = 6;
  EXPECT_EQ(layout_load(BusLayout::kBroadcast, six, 1000.0).cyclic_bits.nominal, 855u);
}

TEST(BusLayout, CanFdByHand) {
  // SYNC classic 55 bits; FD RPDO 4 x (controlword + torque) = 16 B: 33 nominal + 194 data;
  // 4 x FD TPDO 6 B: 33 + 94 each. Nominal 55 + 33 + 132 = 220, data 194 + 376 = 570.
  // At 1 and 5 Mbit/s: 220 us + 114 us = 334 us a cycle.
  const LayoutLoad r = layout_load(BusLayout::kFd, BusParams{}, 2500.0);
  EXPECT_EQ(r.cyclic_bits, (FrameBits{220, 570}));
  EXPECT_NEAR(r.cycle_time_s, 334e-6, 1e-12);
  EXPECT_NEAR(r.cyclic_load, 0.835, 1e-9);
  EXPECT_TRUE(r.fits);                              // the target: >= 2.5 kHz at <= 90 %
  EXPECT_NEAR(r.max_rate_hz, 0.90 / 334e-6, 1e-6);  // 2694.6 Hz
  // A 2 Mbit/s data phase: 220 us + 285 us = 505 us, 1782 Hz at 90 %.
  BusParams slow;
  slow.data_bitrate = 2'000'000;
  EXPECT_NEAR(layout_load(BusLayout::kFd, slow, 1000.0).cycle_time_s, 505e-6, 1e-12);
}

TEST(BusLayout, RateOrdering) {
  // What the layouts are for: each one carries a faster loop than the one before.
  const double per_drive = layout_load(BusLayout::kPerDrive, BusParams{}, 1000.0).max_rate_hz;
  const double broadcast = layout_load(BusLayout::kBroadcast, BusParams{}, 1000.0).max_rate_hz;
  const double fd = layout_load(BusLayout::kFd, BusParams{}, 1000.0).max_rate_hz;
  EXPECT_LT(per_drive, broadcast);
  EXPECT_LT(broadcast, fd);
  EXPECT_FALSE(layout_load(BusLayout::kFd, BusParams{}, 0.0).fits);
  BusParams no_bus;
  no_bus.nominal_bitrate = 0;
  EXPECT_FALSE(layout_load(BusLayout::kPerDrive, no_bus, 1000.0).fits);
}

}  // namespace
}  // namespace dualv::fw
