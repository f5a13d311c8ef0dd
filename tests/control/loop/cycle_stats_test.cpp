#include "control/loop/cycle_stats.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace dualv::control {
namespace {

constexpr std::int64_t kUs = 1000;

TEST(TimingHistogram, ExactPercentilesForMultiplesOfTheResolution) {
  TimingHistogram h(kUs, 2000 * kUs);
  std::vector<std::int64_t> v;
  for (std::int64_t i = 1; i <= 1000; ++i) v.push_back(i * kUs);
  std::shuffle(v.begin(), v.end(), std::mt19937(7));  // order must not matter
  for (auto x : v) h.add(x);
  const TimingSummary s = h.summary();
  EXPECT_EQ(h.count(), 1000);
  EXPECT_EQ(s.min_ns, 1 * kUs);
  EXPECT_EQ(s.median_ns, 500 * kUs);  // nearest rank 500 of 1000
  EXPECT_EQ(s.p99_ns, 990 * kUs);
  EXPECT_EQ(s.p999_ns, 999 * kUs);
  EXPECT_EQ(s.max_ns, 1000 * kUs);
}

TEST(TimingHistogram, OtherValuesRoundUpButNeverPastTheExactMax) {
  TimingHistogram h(kUs, 100 * kUs);
  h.add(1500);
  h.add(1200);
  h.add(3001);
  EXPECT_EQ(h.percentile(5000), 2000);   // 1500 lies in (1 us, 2 us]: reported as 2 us
  EXPECT_EQ(h.percentile(10000), 3001);  // bin edge 4 us clamped to the exact max
  EXPECT_EQ(h.summary().min_ns, 1200);
  EXPECT_EQ(h.percentile(0), 1200 + 800);  // rank 1 -> bin of 1200 -> 2 us
}

TEST(TimingHistogram, OverflowReportsTheExactMaximum) {
  TimingHistogram h(kUs, 10 * kUs);
  for (int i = 0; i < 9; ++i) h.add(5 * kUs);
  h.add(50 * kUs);
  EXPECT_EQ(h.percentile(5000), 5 * kUs);
  EXPECT_EQ(h.percentile(10000), 50 * kUs);
  EXPECT_EQ(h.summary().max_ns, 50 * kUs);
}

TEST(TimingHistogram, NegativeAndZeroSamplesCountInTheFirstBin) {
  TimingHistogram h(kUs, 10 * kUs);
  h.add(-300);
  h.add(0);
  EXPECT_EQ(h.summary().min_ns, -300);
  EXPECT_EQ(h.percentile(10000), 0);
}

TEST(TimingHistogram, EmptyReportsZerosAndResetClears) {
  TimingHistogram h(kUs, 10 * kUs);
  EXPECT_EQ(h.percentile(9990), 0);
  h.add(7 * kUs);
  h.reset();
  EXPECT_EQ(h.count(), 0);
  EXPECT_EQ(h.summary().max_ns, 0);
}

TEST(TimingHistogram, RejectsBadResolution) {
  EXPECT_THROW(TimingHistogram(0, 10), std::invalid_argument);
  EXPECT_THROW(TimingHistogram(10, 5), std::invalid_argument);
}

TEST(CycleStats, DeadlineIsMetAtExactlyTheDeadlineAndMissedOneNanosecondLater) {
  const std::int64_t T = 1'000'000;
  CycleStats s(T, 0, kUs, 20 * T);
  EXPECT_EQ(s.deadline_ns(), T);  // 0 -> deadline = period
  EXPECT_FALSE(s.record(0, T - 1, T - 1));
  EXPECT_FALSE(s.record(0, T, T));
  EXPECT_TRUE(s.record(0, T + 1, T + 1));
  EXPECT_EQ(s.deadline_misses(), 1);
}

TEST(CycleStats, LatenessCountsTowardsTheDeadline) {
  const std::int64_t T = 1'000'000;
  CycleStats s(T, T / 2, kUs, 20 * T);
  EXPECT_FALSE(s.record(100'000, 400'000, 500'000));
  EXPECT_TRUE(s.record(100'001, 400'000, 500'001));
}

TEST(CycleStats, ConsecutiveMissCounterRestartsOnAMetDeadline) {
  const std::int64_t T = 1000;
  CycleStats s(T, 0, 1, 10 * T);
  for (std::int64_t r : {T + 1, T + 1, T + 1, T, T + 1}) s.record(0, r, r);
  EXPECT_EQ(s.deadline_misses(), 4);
  EXPECT_EQ(s.consecutive_misses(), 1);
  EXPECT_EQ(s.summary().max_consecutive_misses, 3);
  s.reset();
  EXPECT_EQ(s.summary().max_consecutive_misses, 0);
  EXPECT_EQ(s.cycles(), 0);
}

TEST(CycleStats, FormatsAReadableReport) {
  CycleStats s(1'000'000, 0, kUs, 20'000'000);
  s.record(2 * kUs, 15 * kUs, 17 * kUs);
  s.record(3 * kUs, 1200 * kUs, 1203 * kUs);
  const std::string text = format_loop_stats(s.summary());
  EXPECT_NE(text.find("loop: 2 cycles at 1000 Hz (deadline 1000 us), 1 deadline misses"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("max 1200.0 us"), std::string::npos) << text;
}

}  // namespace
}  // namespace dualv::control
