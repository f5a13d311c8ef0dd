// The stop latch: requests from other threads, condition vs reset-cleared causes.
#include "safety/estop_latch.hpp"

#include <gtest/gtest.h>

#include <csignal>
#include <thread>
#include <vector>

namespace dualv::safety {
namespace {

TEST(EstopLatch, RequestsFromManyThreadsAreNeverLost) {
  EstopLatch latch;
  std::vector<std::thread> ts;
  for (int t = 0; t < 3; ++t)
    ts.emplace_back([&latch, t] { latch.request_stop(static_cast<StopSource>(t)); });
  for (auto& t : ts) t.join();
  EXPECT_EQ(latch.take_stop_requests(),
            bit(Fault::kEstopLcm) | bit(Fault::kEstopSignal) | bit(Fault::kEstopCli));
  EXPECT_EQ(latch.take_stop_requests(), 0u);  // taken once
}

EstopLatch* g_latch = nullptr;
extern "C" void on_signal(int) { g_latch->request_stop(StopSource::kSignal); }

TEST(EstopLatch, UsableFromASignalHandler) {
  EstopLatch latch;
  g_latch = &latch;
  auto old = std::signal(SIGUSR1, on_signal);
  std::raise(SIGUSR1);
  std::signal(SIGUSR1, old);
  EXPECT_EQ(latch.take_stop_requests(), bit(Fault::kEstopSignal));
}

TEST(EstopLatch, ConditionCausesBlockTheResetUntilGone) {
  EstopLatch latch;
  EXPECT_EQ(latch.latch(bit(Fault::kEstopLcm) | bit(Fault::kDriveLost)),
            bit(Fault::kEstopLcm) | bit(Fault::kDriveLost));
  EXPECT_EQ(latch.latch(bit(Fault::kDriveLost)), 0u);  // already latched: not new
  // The drive is still lost: refused, nothing cleared.
  EXPECT_EQ(latch.try_reset(bit(Fault::kDriveLost)), bit(Fault::kDriveLost));
  EXPECT_TRUE(latch.any());
  // A momentary cause (the LCM request) does not block, even if it "repeats".
  EXPECT_EQ(latch.try_reset(bit(Fault::kEstopLcm)), 0u);
  EXPECT_FALSE(latch.any());
}

}  // namespace
}  // namespace dualv::safety
