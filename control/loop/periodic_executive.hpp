#pragma once
// The periodic executive of the real-time thread: calls a noexcept cycle
// function at a fixed rate, on absolute release times (clock_nanosleep with
// TIMER_ABSTIME on the real clock), and measures every cycle.
//
// Set-up (prepare_realtime) tries SCHED_FIFO, mlockall and CPU affinity. Each
// that is not permitted becomes a warning saying what to fix; the loop still
// runs, without real-time guarantees, so development machines and CI work.
//
// Overrun policy: when a cycle completes after the next release time, the
// releases it ran into are skipped (counted as overruns) and the loop waits for
// the next one on the original grid. It never runs a burst of catch-up cycles,
// which would send several torque commands within one bus period.
//
// Real-time safety of run(): after prepare_realtime, nothing in the loop
// allocates, locks, logs or throws; the only syscalls are the clock's.
#include <atomic>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include "control/loop/cycle_stats.hpp"
#include "control/loop/loop_clock.hpp"

namespace dualv {
class YamlReader;
}

namespace dualv::control {

struct ExecutiveConfig {
  std::int64_t period_ns = 1'000'000;  // 1 kHz
  std::int64_t deadline_ns = 0;        // <= 0: deadline = period
  int priority = 80;                   // SCHED_FIFO priority 1..99; 0 = do not ask
  int cpu = -1;                        // pin the loop thread to this CPU; -1 = do not pin
  bool lock_memory = true;             // mlockall(MCL_CURRENT | MCL_FUTURE)
  bool realtime = true;                // false: skip all of the above (sim clock, tests)
  std::int64_t stats_resolution_ns = 1'000;
  std::int64_t stats_range_ns = 20'000'000;
  // `loop.idle`: what the loop does when nothing is followed (executor.hpp IdleMode):
  // false = "disabled" (drives disabled at 0 N m), true = "hold" (after a normal end the final
  // pose is held). Read here so the whole `loop:` section has one reader.
  bool idle_hold = false;
};

// Reads a `loop:` map: rate_hz (required), deadline_fraction (0.05..1,
// default 1), priority (0..99, default 80), cpu (-1.., default -1),
// lock_memory (default true), stats_resolution_us (default 1),
// stats_range_ms (default 20), idle (disabled | hold, default disabled). Problems are recorded in
// the reader's sink with their key paths; unknown keys are rejected.
ExecutiveConfig read_executive_config(YamlReader& loop);

// What set-up obtained; warnings say what to fix on the target.
struct RealtimeStatus {
  bool attempted = false;
  bool sched_fifo = false;
  bool memory_locked = false;
  bool affinity_set = false;
  std::vector<std::string> warnings;
  bool fully_realtime() const noexcept { return sched_fifo && memory_locked; }
};

// Passed to the cycle function; times on the loop clock, in ns.
struct CycleInfo {
  std::int64_t cycle = 0;       // 0 for the first cycle of a run
  std::int64_t release_ns = 0;  // scheduled start of this cycle
  std::int64_t wake_ns = 0;     // when the thread actually woke
  std::int64_t lateness_ns = 0;
  std::int64_t period_ns = 0;
  std::int64_t skipped_releases = 0;    // releases skipped just before this cycle (overrun)
  std::int32_t consecutive_misses = 0;  // up to and including the previous cycle
  const CycleStats* stats = nullptr;    // read-only view, e.g. for a periodic summary()
};

enum class CycleResult { kContinue, kStop };

struct RunReport {
  std::int64_t cycles = 0;
  bool stop_requested = false;  // ended by request_stop() rather than by the callback or max_cycles
  LoopStatsSummary stats;
};

class PeriodicExecutive {
 public:
  // `clock` schedules and measures lateness; `work_clock`, when given, measures
  // the duration of the cycle work instead (e.g. the real clock while the
  // schedule runs on a SimClock, so a fast simulation still reports real
  // compute time). Throws std::invalid_argument on a bad config (set-up only).
  PeriodicExecutive(const ExecutiveConfig& config, LoopClock& clock,
                    LoopClock* work_clock = nullptr);

  // Applies SCHED_FIFO, CPU affinity (to the calling thread: call it from the
  // thread that will run the loop) and mlockall, and pre-faults the stack.
  // Idempotent; run() calls it when it has not been called. Allocates.
  const RealtimeStatus& prepare_realtime();
  const RealtimeStatus& realtime_status() const noexcept { return rt_; }
  // Back to normal scheduling (SCHED_OTHER) for the calling thread, when prepare_realtime()
  // obtained SCHED_FIFO for it: for a loop that ran in a thread which goes on with other work.
  void release_realtime() noexcept;

  // Runs `fn(const CycleInfo&) noexcept -> CycleResult` every period until it
  // returns kStop, request_stop() is called, or max_cycles (> 0) cycles ran.
  // Statistics are reset at the start of each run.
  template <typename Fn>
  RunReport run(Fn&& fn, std::int64_t max_cycles = 0) {
    using F = std::remove_reference_t<Fn>;
    static_assert(std::is_nothrow_invocable_r_v<CycleResult, F&, const CycleInfo&>,
                  "the cycle function must be noexcept and return CycleResult");
    return run_impl(
        [](void* ctx, const CycleInfo& info) noexcept { return (*static_cast<F*>(ctx))(info); },
        const_cast<void*>(static_cast<const void*>(&fn)), max_cycles);
  }

  // The same loop in pull form, for code that keeps its own control flow between cycles
  // (`dualv selftest`'s scenarios): begin(); then per cycle next() (sleeps until the release)
  // ... work ... done(); finally end(). Same schedule, overrun policy and statistics as run().
  void begin();
  const CycleInfo& next() noexcept;
  void done() noexcept;
  RunReport end() noexcept;

  // Thread- and async-signal-safe: the loop ends after the current cycle. A
  // request made before run() starts makes it return before the first cycle.
  void request_stop() noexcept { stop_.store(true, std::memory_order_relaxed); }

  // Not synchronised: read it after run() returns, or inside the cycle
  // through CycleInfo::stats (same thread).
  const CycleStats& stats() const noexcept { return stats_; }
  const ExecutiveConfig& config() const noexcept { return config_; }

 private:
  using Trampoline = CycleResult (*)(void*, const CycleInfo&) noexcept;
  RunReport run_impl(Trampoline fn, void* ctx, std::int64_t max_cycles);

  ExecutiveConfig config_;
  LoopClock& clock_;
  LoopClock* work_clock_;
  // The cycle in progress (begin/next/done).
  CycleInfo info_;
  RunReport report_;
  std::int64_t release_ = 0;
  std::int64_t skipped_ = 0;
  std::int64_t work_start_ = 0;
  CycleStats stats_;
  RealtimeStatus rt_;
  std::atomic<bool> stop_{false};
};

}  // namespace dualv::control
