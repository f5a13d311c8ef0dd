#include "common/spsc_queue.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <thread>
#include <vector>

namespace dualv {
namespace {

TEST(SpscQueue, EmptyPopFailsAndLeavesOutputUntouched) {
  SpscQueue<int, 4> q;
  int out = 42;
  EXPECT_FALSE(q.try_pop(out));
  EXPECT_EQ(out, 42);
  EXPECT_EQ(q.size_approx(), 0u);
}

TEST(SpscQueue, FullRingDropsNewestAndCountsIt) {
  SpscQueue<int, 4> q;
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(q.try_push(i));
  EXPECT_FALSE(q.try_push(99));
  EXPECT_FALSE(q.try_push(100));
  EXPECT_EQ(q.dropped(), 2u);
  EXPECT_EQ(q.size_approx(), 4u);
  int out = -1;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(q.try_pop(out));
    EXPECT_EQ(out, i);  // the dropped 99 and 100 never appear
  }
  EXPECT_FALSE(q.try_pop(out));
}

TEST(SpscQueue, WrapsAroundManyTimesInOrder) {
  SpscQueue<std::uint64_t, 8> q;
  std::uint64_t next_in = 0, next_out = 0;
  // Uneven push/pop batch sizes move the indices across the wrap point often.
  for (int round = 0; round < 1000; ++round) {
    for (int k = 0; k < 1 + round % 7; ++k)
      if (q.try_push(next_in)) ++next_in;  // a refused value is pushed again next round
    std::uint64_t v = 0;
    for (int k = 0; k < 1 + (round + 5) % 7 && q.try_pop(v); ++k) {
      ASSERT_EQ(v, next_out);
      ++next_out;
    }
    // Everything pushed is either popped or still queued.
    ASSERT_EQ(next_in, next_out + q.size_approx());
  }
  EXPECT_GT(next_in, 1000u);
  EXPECT_GT(q.dropped(), 0u);  // the batches were uneven enough to fill the ring
}

// Two threads, two million elements through a small ring: every element arrives
// exactly once and in order. The producer retries when full, so nothing is lost;
// each refused attempt is a counted drop, and the tally must match exactly.
TEST(SpscQueue, TwoThreadStressKeepsOrderWithoutLossOrDuplication) {
  constexpr std::uint64_t kCount = 2'000'000;
  struct Item {
    std::uint64_t seq;
    std::uint64_t check;  // a second word: a torn copy would not match seq
  };
  SpscQueue<Item, 64> q;
  std::uint64_t refused = 0;
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kCount; ++i) {
      while (!q.try_push(Item{i, ~i})) ++refused;
    }
  });
  std::uint64_t expected = 0;
  std::uint64_t bad = 0;
  Item item{};
  while (expected < kCount) {
    if (!q.try_pop(item)) continue;
    if (item.seq != expected || item.check != ~expected) ++bad;
    expected = item.seq + 1;
  }
  producer.join();
  EXPECT_EQ(bad, 0u);
  EXPECT_EQ(expected, kCount);
  EXPECT_FALSE(q.try_pop(item));  // no duplicate or extra element left behind
  EXPECT_EQ(q.dropped(), refused);
}

}  // namespace
}  // namespace dualv
