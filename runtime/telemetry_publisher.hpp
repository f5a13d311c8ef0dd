#pragma once
// Publishes telemetry from the real-time cycle on LCM without the cycle ever
// waiting: the cycle pushes plain samples into lock-free SPSC queues, and a
// non-real-time thread drains them, converts them to dualv_lcm messages and
// publishes them.
//
// The LCM URL decides where they go. log_url(path) writes an LCM event log
// through LCM's file provider (no network; read it with lcm-logplayer or
// lcm::LogFile); a udpm:// URL publishes live (see channels.hpp).
//
// Threads: push_*() are the producer side and must all be called from one
// thread (the RT loop); everything else from the owning (non-RT) thread.
//
// Typical use (`dualv run`):
//   TelemetryPublisher telemetry(lcm_url.empty() ? log_url(default_log_path()) : lcm_url);
//   telemetry.start();
//   executive.run([&](const control::CycleInfo& info) noexcept {
//     StateSample s; /* fill from the cycle */ telemetry.push_state(s);
//     if (info.cycle % 1000 == 999) {  // about once a second at 1 kHz
//       LoopStatsSample l; l.stats = info.stats->summary(); telemetry.push_loop_stats(l);
//     }
//     return control::CycleResult::kContinue;
//   });
//   telemetry.push_loop_stats(final_sample);  // from RunReport::stats
//   telemetry.stop();                         // publishes what is still queued
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <variant>

#include "common/spsc_queue.hpp"
#include "runtime/telemetry.hpp"

namespace lcm {
class LCM;
}

namespace dualv::runtime {

// "file:///abs/path.lcmlog?mode=w": the URL of an LCM log written by LCM's file provider.
std::string log_url(const std::string& path);
// "dualv-YYYYMMDD-HHMMSS.lcmlog" in `dir` (local time): the default log of `dualv run`.
std::string default_log_path(const std::string& dir = ".");

// Wall clock in microseconds since 1970 (LCM's utime convention).
std::int64_t wall_utime() noexcept;

struct TelemetryCounters {
  std::uint64_t states = 0;  // published
  std::uint64_t faults = 0;
  std::uint64_t loop_stats = 0;
  std::uint64_t states_dropped = 0;  // queue full: the publisher fell behind
  std::uint64_t events_dropped = 0;  // faults or loop stats lost (should stay 0)
  std::uint64_t publish_errors = 0;  // lcm publish() failed
};

class TelemetryPublisher {
 public:
  static constexpr std::size_t kStateQueue = 4096;  // 4 s at 1 kHz
  static constexpr std::size_t kEventQueue = 256;

  // Opens its own LCM instance on `url`; throws std::runtime_error naming the
  // URL when LCM cannot open it (bad provider, unwritable log path).
  // state_decimation k publishes every k-th state sample (1 = all).
  explicit TelemetryPublisher(const std::string& url, int state_decimation = 1);
  // Publishes on an LCM instance owned by the caller (tests with memq://).
  explicit TelemetryPublisher(lcm::LCM& lcm, int state_decimation = 1);
  ~TelemetryPublisher();  // stop()
  TelemetryPublisher(const TelemetryPublisher&) = delete;
  TelemetryPublisher& operator=(const TelemetryPublisher&) = delete;

  // Starts the publisher thread (drains every poll_ms).
  void start(int poll_ms = 2);
  // Stops the thread after publishing everything still queued. Idempotent.
  void stop();

  // Producer side (RT thread), noexcept and allocation-free. Return false when
  // the queue is full; the sample is dropped and counted.
  bool push_state(const StateSample& s) noexcept { return states_.try_push(s); }
  bool push_fault(const FaultSample& f) noexcept { return events_.try_push(Event{f}); }
  bool push_loop_stats(const LoopStatsSample& s) noexcept { return events_.try_push(Event{s}); }
  // Samples lost so far (for FLAG_TELEMETRY_DROPPED and loop_stats_t); any thread.
  std::uint64_t dropped() const noexcept { return states_.dropped() + events_.dropped(); }

  // Publishes everything queued now, on the calling thread: the publisher
  // thread's body, and for tests that step it by hand. Only while the thread
  // is not running (the queues have one consumer). Returns messages published.
  std::size_t drain();
  TelemetryCounters counters() const noexcept;
  const std::string& url() const noexcept { return url_; }

 private:
  using Event = std::variant<FaultSample, LoopStatsSample>;
  void publish_state(const StateSample& s);
  void publish_event(const Event& e);

  std::unique_ptr<lcm::LCM> owned_;
  lcm::LCM* lcm_;
  std::string url_;
  int decimation_;
  std::uint64_t state_seen_ = 0;
  SpscQueue<StateSample, kStateQueue> states_;
  SpscQueue<Event, kEventQueue> events_;
  std::atomic<std::uint64_t> n_states_{0}, n_faults_{0}, n_stats_{0}, n_errors_{0};
  std::atomic<bool> running_{false};
  std::thread thread_;
};

}  // namespace dualv::runtime
