#pragma once
// The real-time thread that runs an Executor (executor.hpp) on the periodic executive
// (periodic_executive.hpp) from go() until the executor ends (shutdown) or stop().
//
// launch() starts the thread early, before the drives are booted: the thread applies
// SCHED_FIFO, CPU affinity and mlockall (prepare_realtime: slow, and to this thread only; the
// process's other threads keep normal scheduling) and then waits. go() hands it the executor
// and the first cycle follows at once, so the time between priming the drives and the first
// cycle is a thread wake-up, not a set-up (docs/architecture.md: the drives' RPDO deadline is
// running).
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>

#include "control/loop/executor.hpp"
#include "control/loop/periodic_executive.hpp"

namespace dualv::control {

class LoopThread {
 public:
  // `work_clock` as PeriodicExecutive's. Both clocks must outlive the thread.
  LoopThread(const ExecutiveConfig& config, LoopClock& clock, LoopClock* work_clock = nullptr);
  ~LoopThread();  // stop() and join
  LoopThread(const LoopThread&) = delete;
  LoopThread& operator=(const LoopThread&) = delete;

  // Starts the thread and waits until it is prepared; returns what set-up obtained.
  const RealtimeStatus& launch();
  // Runs `executor` from now on (the first cycle's release is the moment the thread wakes).
  void go(Executor& executor);
  // Ends the loop after the current cycle (any thread); the executor's own shutdown
  // (Executor::submit(kShutdown)) is the normal way: it stops the motion first.
  void stop() noexcept;
  // Waits for the loop to end; the executive's report (cycles, timing).
  RunReport join();
  bool running() const noexcept { return running_.load(std::memory_order_acquire); }
  // Wake-up time of the first cycle on the loop clock [ns] (0 before it).
  std::int64_t first_cycle_ns() const noexcept { return first_ns_.load(); }
  std::int64_t go_ns() const noexcept { return go_ns_; }

 private:
  void body();

  PeriodicExecutive executive_;
  LoopClock& clock_;
  std::thread thread_;
  std::mutex mutex_;  // set-up hand-shake only (launch / go), never during the loop
  std::condition_variable cv_;
  bool prepared_ = false;
  bool cancelled_ = false;
  Executor* executor_ = nullptr;
  std::int64_t go_ns_ = 0;
  std::atomic<std::int64_t> first_ns_{0};
  std::atomic<bool> running_{false};
  RunReport report_;
};

}  // namespace dualv::control
