// drivers/canopen/cycle_clock.hpp: inside a cycle every read is the loop's wake-up time and
// the base clock is not read at all (the system call it saves); outside, the base clock.
#include "drivers/canopen/cycle_clock.hpp"

#include <gtest/gtest.h>

#include <cstdint>

namespace dualv::drivers::canopen {
namespace {

// A base clock that counts its reads (each one a system call on a real target).
class CountingClock final : public Clock {
 public:
  std::uint64_t now_ns() const noexcept override {
    ++reads;
    return t;
  }
  std::uint64_t t = 5'000'000'000;
  mutable int reads = 0;
};

TEST(CycleClock, OutsideACycleReadsTheBaseClock) {
  CountingClock base;
  CycleClock clock(base);
  EXPECT_EQ(clock.now_ns(), 5'000'000'000u);
  base.t = 5'000'000'123;
  EXPECT_EQ(clock.now_ns(), 5'000'000'123u);
  EXPECT_EQ(base.reads, 2);
}

TEST(CycleClock, InsideACycleEveryReadIsTheWakeUpAndTheBaseIsNotRead) {
  CountingClock base;
  CycleClock clock(base);
  clock.begin_cycle(7'000'000'000);
  base.t = 7'000'050'000;  // the real time moved on during the cycle
  for (int i = 0; i < 3; ++i) EXPECT_EQ(clock.now_ns(), 7'000'000'000u);  // read + write + checks
  EXPECT_EQ(base.reads, 0);
  clock.end_cycle();
  EXPECT_EQ(clock.now_ns(), 7'000'050'000u);  // shut-down and priming see the real time again
  EXPECT_EQ(base.reads, 1);
}

TEST(CycleClock, AWakeUpAtTimeZeroStillCountsAsInACycle) {
  CountingClock base;
  CycleClock clock(base);
  clock.begin_cycle(0);  // a manual loop clock starting at 0
  EXPECT_LE(clock.now_ns(), 1u);
  EXPECT_EQ(base.reads, 0);
}

}  // namespace
}  // namespace dualv::drivers::canopen
