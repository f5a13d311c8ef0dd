// Seeded property tests: random and hostile controller outputs (huge, NaN, Inf, alternating
// sign, steps, noise) through the limiter and the whole filter. Whatever comes in, what
// goes out is finite, never above torque.max, never changes faster than torque.max_rate
// while the drives keep power, and is exactly 0 N m whenever the drives are disabled.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "safety_bench.hpp"

namespace dualv::safety::test {
namespace {

double hostile(std::mt19937_64& rng, int k, double prev) {
  std::uniform_int_distribution<int> kind(0, 9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  switch (kind(rng)) {
    case 0:
      return std::numeric_limits<double>::quiet_NaN();
    case 1:
      return (k % 2 ? 1 : -1) * std::numeric_limits<double>::infinity();
    case 2:
      return u(rng) * 1e300;
    case 3:
      return (k % 2 ? 1.0 : -1.0) * 1000.0;  // alternating sign
    case 4:
      return u(rng) > 0 ? 127.0 : -127.0;  // steps to the drive peak
    case 5:
      return std::numeric_limits<double>::denorm_min();
    case 6:
      return prev + u(rng) * 0.5;  // a plausible walk
    case 7:
      return -std::numeric_limits<double>::max();
    default:
      return u(rng) * 80.0;
  }
}

TEST(SafetyProperty, LimiterNeverExceedsAbsoluteOrRate) {
  std::mt19937_64 rng(20261125);
  const double max = 60.0, step = 30.0;
  std::array<double, 4> prev{}, in{}, out{};
  for (int k = 0; k < 200000; ++k) {
    for (int i = 0; i < 4; ++i) in[i] = hostile(rng, k, prev[i]);
    limit_torque(in.data(), prev.data(), 4, max, step, out.data());
    for (int i = 0; i < 4; ++i) {
      ASSERT_TRUE(std::isfinite(out[i])) << k;
      ASSERT_LE(std::abs(out[i]), max) << k;
      ASSERT_LE(std::abs(out[i] - prev[i]), step * (1 + 1e-12)) << k;
    }
    prev = out;
  }
}

TEST(SafetyProperty, FilterOutputRespectsEveryLimitUnderHostileCommands) {
  for (const std::uint64_t seed : {1ull, 42ull, 20261125ull}) {
    SafetyConfig c;
    c.torque.max = 45.0;
    c.torque.max_rate = 5000.0;  // 5 N m per cycle: the rate limit matters
    Bench b(c);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> jitter(-2e-5, 2e-5);
    ASSERT_EQ(b.arm(), ArmStatus::kOk);
    const double step = b.filter->limits().torque_step;
    std::array<double, drivers::kMaxDrives> prev{};
    int stops = 0, operational = 0;
    std::bernoulli_distribution clean(0.97);
    for (int k = 0; k < 50000; ++k) {
      // Mostly well-behaved commands with hostile bursts, so the filter also spends time
      // passing (and limiting) commands rather than only stopping.
      for (int i = 0; i < 4; ++i) {
        b.in.command.torque[i] = clean(rng) ? std::clamp(prev[i] + jitter(rng) * 1e5, -40.0, 40.0)
                                            : hostile(rng, k, prev[i]);
        b.fb.drive[i].position += jitter(rng);  // a little (real) motion
      }
      const SafetyState s = b.step();
      for (int i = 0; i < 4; ++i) {
        const double t = b.out.torque[i];
        ASSERT_TRUE(std::isfinite(t)) << seed << " k " << k;
        ASSERT_LE(std::abs(t), c.torque.max) << seed << " k " << k;
        if (b.out.request == drivers::DriveRequest::kDisable ||
            b.out.request == drivers::DriveRequest::kFaultReset)
          ASSERT_EQ(t, 0.0) << seed << " k " << k;  // STO: torque off, exempt from the ramp
        else
          ASSERT_LE(std::abs(t - prev[i]), step * (1 + 1e-12)) << seed << " k " << k;
      }
      if (s == SafetyState::kOperational) ++operational;
      prev = b.out.torque;
      if (s == SafetyState::kSto) {  // recover and go again
        ++stops;
        b.filter->request_reset();
        if (b.step() == SafetyState::kDisabled) {
          ASSERT_EQ(b.arm(), ArmStatus::kOk);
        }
        prev = b.out.torque;
      }
      b.events();
    }
    EXPECT_GT(stops, 10) << seed;
    EXPECT_GT(operational, 10000) << seed;
  }
}

}  // namespace
}  // namespace dualv::safety::test
