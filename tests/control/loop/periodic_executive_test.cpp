#include "control/loop/periodic_executive.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <thread>
#include <vector>

#include "common/yaml_reader.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::control {
namespace {

constexpr std::int64_t kT = 1'000'000;  // 1 kHz

ExecutiveConfig sim_config() {
  ExecutiveConfig c;
  c.period_ns = kT;
  c.realtime = false;  // the sim clock never sleeps: nothing to make real-time
  c.stats_resolution_ns = 1000;
  c.stats_range_ns = 20 * kT;
  return c;
}

TEST(PeriodicExecutive, StatisticsMatchInjectedCycleDurations) {
  SimClock clock(5'000'000'000);
  PeriodicExecutive ex(sim_config(), clock);
  // Work durations 1..1000 us in a scrambled but fixed order (i * 7 mod 1000).
  std::vector<std::int64_t> releases;
  releases.reserve(1000);
  auto report = ex.run(
      [&](const CycleInfo& info) noexcept {
        releases.push_back(info.release_ns);
        clock.advance(((info.cycle * 7) % 1000 + 1) * 1000);
        return CycleResult::kContinue;
      },
      1000);
  EXPECT_EQ(report.cycles, 1000);
  EXPECT_FALSE(report.stop_requested);
  const auto& s = report.stats;
  EXPECT_EQ(s.cycles, 1000);
  EXPECT_EQ(s.cycle.min_ns, 1000);
  EXPECT_EQ(s.cycle.median_ns, 500'000);
  EXPECT_EQ(s.cycle.p99_ns, 990'000);
  EXPECT_EQ(s.cycle.p999_ns, 999'000);
  EXPECT_EQ(s.cycle.max_ns, 1'000'000);
  // The longest cycle takes exactly one period: it meets its deadline.
  EXPECT_EQ(s.deadline_misses, 0);
  EXPECT_EQ(s.overruns, 0);
  EXPECT_EQ(s.lateness.max_ns, 0);
  // Releases are on an exact grid from the start time: no drift.
  for (std::size_t i = 0; i < releases.size(); ++i)
    ASSERT_EQ(releases[i], 5'000'000'000 + static_cast<std::int64_t>(i) * kT);
}

struct Boundary {
  std::int64_t work_ns;
  bool missed;
  std::int64_t skipped;
};

class DeadlineBoundary : public ::testing::TestWithParam<Boundary> {};

TEST_P(DeadlineBoundary, MissAndOverrunCountedExactly) {
  const Boundary b = GetParam();
  SimClock clock;
  PeriodicExecutive ex(sim_config(), clock);
  std::vector<CycleInfo> seen;
  seen.reserve(2);
  auto report = ex.run(
      [&](const CycleInfo& info) noexcept {
        seen.push_back(info);
        if (info.cycle == 0) clock.advance(b.work_ns);
        return CycleResult::kContinue;
      },
      2);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(report.stats.deadline_misses, b.missed ? 1 : 0);
  EXPECT_EQ(report.stats.overruns, b.skipped);
  EXPECT_EQ(seen[1].skipped_releases, b.skipped);
  EXPECT_EQ(seen[1].consecutive_misses, b.missed ? 1 : 0);
  // The second cycle starts on the grid, after the skipped releases.
  EXPECT_EQ(seen[1].release_ns, (1 + b.skipped) * kT);
  EXPECT_EQ(seen[1].lateness_ns, 0);
}

INSTANTIATE_TEST_SUITE_P(AtTminus1TandTplus1, DeadlineBoundary,
                         ::testing::Values(Boundary{kT - 1, false, 0}, Boundary{kT, false, 0},
                                           Boundary{kT + 1, true, 1}, Boundary{3 * kT, true, 2},
                                           Boundary{3 * kT + 1, true, 3}));

TEST(PeriodicExecutive, ShorterDeadlineThanPeriod) {
  ExecutiveConfig c = sim_config();
  c.deadline_ns = kT / 2;
  SimClock clock;
  PeriodicExecutive ex(c, clock);
  const std::int64_t work[] = {kT / 2 - 1, kT / 2, kT / 2 + 1, 0};
  auto report = ex.run(
      [&](const CycleInfo& info) noexcept {
        clock.advance(work[info.cycle]);
        return CycleResult::kContinue;
      },
      4);
  EXPECT_EQ(report.stats.deadline_misses, 1);
  EXPECT_EQ(report.stats.overruns, 0);  // missing a deadline is not skipping a release
}

TEST(PeriodicExecutive, InjectedWakeLatencyIsMeasuredAndCountsTowardsTheDeadline) {
  SimClock clock;
  PeriodicExecutive ex(sim_config(), clock);
  clock.set_wake_latency(200'000);  // every wake-up 200 us late
  auto report = ex.run(
      [&](const CycleInfo&) noexcept {
        clock.advance(800'000);  // 200 + 800 = exactly the deadline
        return CycleResult::kContinue;
      },
      10);
  EXPECT_EQ(report.stats.lateness.min_ns, 200'000);
  EXPECT_EQ(report.stats.lateness.max_ns, 200'000);
  EXPECT_EQ(report.stats.cycle.median_ns, 800'000);
  EXPECT_EQ(report.stats.deadline_misses, 0);
}

TEST(PeriodicExecutive, ConsecutiveMissesAreVisibleToTheCycle) {
  SimClock clock;
  PeriodicExecutive ex(sim_config(), clock);
  // Cycles 0..2 overrun by 1 ns each, cycle 3 is short, cycle 4 overruns.
  const bool late[] = {true, true, true, false, true, false};
  std::vector<std::int32_t> consecutive;
  consecutive.reserve(6);
  auto report = ex.run(
      [&](const CycleInfo& info) noexcept {
        consecutive.push_back(info.consecutive_misses);
        if (late[info.cycle]) clock.advance(kT + 1);
        return CycleResult::kContinue;
      },
      6);
  EXPECT_EQ(consecutive, (std::vector<std::int32_t>{0, 1, 2, 3, 0, 1}));
  EXPECT_EQ(report.stats.deadline_misses, 4);
  EXPECT_EQ(report.stats.max_consecutive_misses, 3);
  EXPECT_EQ(report.stats.consecutive_misses, 0);
}

TEST(PeriodicExecutive, StopsWhenTheCycleSaysSoOrOnRequest) {
  SimClock clock;
  PeriodicExecutive ex(sim_config(), clock);
  auto r1 = ex.run([](const CycleInfo& i) noexcept {
    return i.cycle == 4 ? CycleResult::kStop : CycleResult::kContinue;
  });
  EXPECT_EQ(r1.cycles, 5);
  EXPECT_FALSE(r1.stop_requested);

  auto r2 = ex.run([&](const CycleInfo& i) noexcept {
    if (i.cycle == 9) ex.request_stop();  // e.g. from a signal handler
    return CycleResult::kContinue;
  });
  EXPECT_EQ(r2.cycles, 10);  // the current cycle completes, no further one starts
  EXPECT_TRUE(r2.stop_requested);
  EXPECT_EQ(r2.stats.cycles, 10);  // statistics are per run
}

TEST(PeriodicExecutive, SeparateWorkClockMeasuresCycleTime) {
  SimClock schedule;
  SimClock work;
  PeriodicExecutive ex(sim_config(), schedule, &work);
  auto report = ex.run(
      [&](const CycleInfo&) noexcept {
        work.advance(3000);  // compute time; simulated time does not move
        return CycleResult::kContinue;
      },
      100);
  EXPECT_EQ(report.stats.cycle.max_ns, 3000);
  EXPECT_EQ(report.stats.deadline_misses, 0);
  EXPECT_EQ(schedule.now_ns(), 99 * kT);  // ran as fast as possible on sim time
}

TEST(PeriodicExecutive, CycleDoesNotAllocate) {
  SimClock clock;
  PeriodicExecutive ex(sim_config(), clock);
  ex.prepare_realtime();
  long during = -1;
  auto report = ex.run(
      [&](const CycleInfo& info) noexcept {
        if (info.cycle == 0) {
          dualv::test::start_counting();
        }
        clock.advance(1000 * (info.cycle % 50));
        if (info.cycle % 100 == 99) (void)info.stats->summary();  // periodic report
        if (info.cycle == 9999) {
          during = dualv::test::stop_counting();
        }
        return CycleResult::kContinue;
      },
      10000);
  EXPECT_EQ(report.cycles, 10000);
  EXPECT_EQ(during, 0);
}

TEST(PeriodicExecutive, RealClockSmokeRunsTheRequestedCycles) {
  // Never asserts timing: CI machines and the UML guest are not real-time.
  ExecutiveConfig c;
  c.period_ns = 500'000;
  c.priority = 10;
  c.lock_memory = false;  // mlockall here would pin all test memory for nothing
  MonotonicClock clock;
  PeriodicExecutive ex(c, clock);
  RealtimeStatus rt;
  RunReport report;
  std::int64_t last_release = 0;
  bool monotonic = true;
  // Its own thread, as in the application: SCHED_FIFO (when granted) stays
  // with that thread and does not leak into the rest of the test binary.
  std::thread loop([&] {
    rt = ex.prepare_realtime();
    report = ex.run(
        [&](const CycleInfo& info) noexcept {
          if (info.release_ns <= last_release) monotonic = false;
          last_release = info.release_ns;
          return CycleResult::kContinue;
        },
        50);
  });
  loop.join();
  EXPECT_TRUE(rt.attempted);
  for (const auto& w : rt.warnings) EXPECT_FALSE(w.empty());
  if (!rt.sched_fifo) {
    EXPECT_FALSE(rt.warnings.empty()) << "a refusal must be explained";
  }
  EXPECT_EQ(report.cycles, 50);
  EXPECT_EQ(report.stats.cycles, 50);
  EXPECT_TRUE(monotonic);
  EXPECT_GE(report.stats.lateness.max_ns, report.stats.lateness.min_ns);
}

TEST(ExecutiveConfig, ReadsALoopSection) {
  ConfigProblems problems;
  YamlReader top(YAML::Load("loop: {rate_hz: 500, priority: 90, cpu: 3, deadline_fraction: 0.5}"),
                 "", problems.sink());
  YamlReader loop = top.child("loop");
  ExecutiveConfig c = read_executive_config(loop);
  EXPECT_TRUE(problems.empty());
  EXPECT_EQ(c.period_ns, 2'000'000);
  EXPECT_EQ(c.deadline_ns, 1'000'000);
  EXPECT_EQ(c.priority, 90);
  EXPECT_EQ(c.cpu, 3);
  EXPECT_TRUE(c.lock_memory);
}

TEST(ExecutiveConfig, NamesBadKeys) {
  ConfigProblems problems;
  YamlReader top(YAML::Load("loop: {rate_hz: 0, priority: 120, cpu: -4, ratehz: 1}"), "",
                 problems.sink());
  YamlReader loop = top.child("loop");
  read_executive_config(loop);
  const auto& p = *problems.sink();
  ASSERT_EQ(p.size(), 4u);
  EXPECT_EQ(p[0], "loop.rate_hz: must be in [1, 20000] (got 0)");
  EXPECT_EQ(p[1], "loop.priority: must be 0 (no SCHED_FIFO) or 1..99 (got 120)");
  EXPECT_EQ(p[2], "loop.cpu: must be -1 (no pinning) or a CPU number (got -4)");
  EXPECT_EQ(p[3], "loop.ratehz: unknown key");
}

}  // namespace
}  // namespace dualv::control
