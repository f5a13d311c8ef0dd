#include "firmware_if/units.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <random>

namespace dualv::fw {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(Units, CountsToRadGolden) {
  EXPECT_DOUBLE_EQ(counts_to_rad(1024, 4096), kPi / 2);
  EXPECT_DOUBLE_EQ(counts_to_rad(-4096, 4096), -2 * kPi);
  EXPECT_DOUBLE_EQ(counts_to_rad(0, 4096), 0.0);
  EXPECT_DOUBLE_EQ(counts_to_rad(12345, 0), 0.0);  // no resolution configured
  EXPECT_EQ(rad_to_counts(kPi, 4096), 2048);
  EXPECT_EQ(rad_to_counts(-kPi / 2, 4096), -1024);
  EXPECT_EQ(rad_to_counts(1.0, 0), 0);
  EXPECT_EQ(counts_per_rev(1u << 20, 1), 1048576u);
  EXPECT_EQ(counts_per_rev(8192, 2), 4096u);
  EXPECT_EQ(counts_per_rev(8192, 0), 0u);
}

TEST(Units, RadToCountsSaturatesAndRejectsNaN) {
  EXPECT_EQ(rad_to_counts(1e12, 4096), std::numeric_limits<std::int32_t>::max());
  EXPECT_EQ(rad_to_counts(-1e12, 4096), std::numeric_limits<std::int32_t>::min());
  EXPECT_EQ(rad_to_counts(std::numeric_limits<double>::quiet_NaN(), 4096), 0);
  EXPECT_EQ(rad_to_counts(std::numeric_limits<double>::infinity(), 4096),
            std::numeric_limits<std::int32_t>::max());
}

TEST(Units, CountsRoundTripSeeded) {
  std::mt19937 rng(1);
  for (std::uint32_t cpr : {4096u, 1u << 20, 1u << 24, 10000u}) {
    for (int i = 0; i < 2000; ++i) {
      const auto c = static_cast<std::int32_t>(rng());
      EXPECT_EQ(rad_to_counts(counts_to_rad(c, cpr), cpr), c) << cpr;
    }
  }
}

TEST(Units, TorqueGolden) {
  // 6076h 127000 mN m = 127 N m; 100 per mille of it = 12.7 N m.
  EXPECT_DOUBLE_EQ(rated_torque_nm(127000), 127.0);
  EXPECT_DOUBLE_EQ(per_mille_to_nm(1000, 127.0), 127.0);
  EXPECT_DOUBLE_EQ(per_mille_to_nm(-250, 40.0), -10.0);
  EXPECT_EQ(nm_to_per_mille(12.7, 127.0), 100);
  EXPECT_EQ(nm_to_per_mille(-10.0, 40.0), -250);
  EXPECT_EQ(nm_to_per_mille(0.0, 40.0), 0);
}

TEST(Units, TorqueRoundsHalfAwayFromZero) {
  // rated 1000 N m: per mille = N m exactly.
  EXPECT_EQ(nm_to_per_mille(0.5, 1000.0), 1);
  EXPECT_EQ(nm_to_per_mille(1.5, 1000.0), 2);
  EXPECT_EQ(nm_to_per_mille(2.5, 1000.0), 3);
  EXPECT_EQ(nm_to_per_mille(-0.5, 1000.0), -1);
  EXPECT_EQ(nm_to_per_mille(-2.5, 1000.0), -3);
  EXPECT_EQ(nm_to_per_mille(0.49, 1000.0), 0);
  EXPECT_EQ(nm_to_per_mille(-0.49, 1000.0), 0);
  EXPECT_EQ(nm_to_per_mille(1.51, 1000.0), 2);
}

TEST(Units, TorqueSaturatesNeverWraps) {
  EXPECT_EQ(nm_to_per_mille(1e9, 1.0), 32767);
  EXPECT_EQ(nm_to_per_mille(-1e9, 1.0), -32768);
  EXPECT_EQ(nm_to_per_mille(32767.6, 1000.0), 32767);  // would round to 32768
  EXPECT_EQ(nm_to_per_mille(-32768.6, 1000.0), -32768);
  EXPECT_EQ(nm_to_per_mille(std::numeric_limits<double>::infinity(), 1.0), 32767);
  EXPECT_EQ(nm_to_per_mille(std::numeric_limits<double>::quiet_NaN(), 1.0), 0);
  EXPECT_EQ(nm_to_per_mille(5.0, 0.0), 0);
  EXPECT_EQ(nm_to_per_mille(5.0, -1.0), 0);
  EXPECT_EQ(nm_to_per_mille(5.0, std::numeric_limits<double>::quiet_NaN()), 0);
}

TEST(Units, MaxTorque) {
  EXPECT_EQ(max_torque_per_mille(12.7, 127.0), 100);
  EXPECT_EQ(max_torque_per_mille(-1.0, 127.0), 0);
  EXPECT_EQ(max_torque_per_mille(1e9, 1.0), 65535);
  EXPECT_EQ(max_torque_per_mille(1.0, 0.0), 0);
}

TEST(Units, TorqueRoundTripWithinHalfStep) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> nm(-100.0, 100.0);
  for (int i = 0; i < 5000; ++i) {
    const double t = nm(rng);
    const double back = per_mille_to_nm(nm_to_per_mille(t, 127.0), 127.0);
    EXPECT_LE(std::abs(back - t), 0.5 * 127.0 / 1000.0 + 1e-12);
  }
}

}  // namespace
}  // namespace dualv::fw
