#include "control/loop/periodic_executive.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <stdexcept>
#include <string>

#include "common/yaml_reader.hpp"

namespace dualv::control {

std::int64_t MonotonicClock::now_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void MonotonicClock::sleep_until_ns(std::int64_t t_ns) noexcept {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(t_ns / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(t_ns % 1'000'000'000);
  // Absolute time: a signal interrupting the sleep just sleeps again to the
  // same instant, without drift.
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

ExecutiveConfig read_executive_config(YamlReader& loop) {
  ExecutiveConfig c;
  // Optional keys are read only when present: the default then comes from
  // ExecutiveConfig, so the values here and in the header cannot disagree.
  const double rate = loop.in_range("rate_hz", 1.0, 20000.0);
  double deadline_fraction = 1.0;
  if (loop.has("deadline_fraction"))
    deadline_fraction = loop.in_range("deadline_fraction", 0.05, 1.0);
  if (loop.has("priority")) {
    c.priority = loop.integer("priority");
    loop.require(c.priority >= 0 && c.priority <= 99, "priority",
                 "must be 0 (no SCHED_FIFO) or 1..99", c.priority);
  }
  if (loop.has("cpu")) {
    c.cpu = loop.integer("cpu");
    loop.require(c.cpu >= -1, "cpu", "must be -1 (no pinning) or a CPU number", c.cpu);
  }
  if (loop.has("lock_memory")) c.lock_memory = loop.boolean("lock_memory");
  if (loop.has("idle")) {
    const std::string idle = loop.string("idle");
    loop.require(
        idle == "disabled" || idle == "hold", "idle",
        "must be disabled (drives disabled at 0 N m) or hold (hold the final pose), got " + idle);
    c.idle_hold = idle == "hold";
  }
  if (loop.has("stats_resolution_us"))
    c.stats_resolution_ns = std::max<std::int64_t>(
        1, std::llround(loop.in_range("stats_resolution_us", 0.001, 1000.0) * 1e3));
  if (loop.has("stats_range_ms"))
    c.stats_range_ns = std::llround(loop.in_range("stats_range_ms", 1.0, 1000.0) * 1e6);
  loop.reject_unknown_keys();
  if (rate > 0) c.period_ns = static_cast<std::int64_t>(std::llround(1e9 / rate));
  c.deadline_ns =
      static_cast<std::int64_t>(std::llround(deadline_fraction * static_cast<double>(c.period_ns)));
  c.stats_range_ns = std::max(c.stats_resolution_ns, c.stats_range_ns);
  return c;
}

PeriodicExecutive::PeriodicExecutive(const ExecutiveConfig& config, LoopClock& clock,
                                     LoopClock* work_clock)
    : config_(config),
      clock_(clock),
      work_clock_(work_clock),
      stats_(config.period_ns, config.deadline_ns, config.stats_resolution_ns,
             config.stats_range_ns) {
  if (config.priority < 0 || config.priority > 99)
    throw std::invalid_argument("periodic executive: priority must be 0..99 (got " +
                                std::to_string(config.priority) + ")");
}

namespace {

// Touches a stack region so its pages are mapped (and, after mlockall, locked)
// before the first cycle: a page fault in the cycle costs tens of microseconds.
void prefault_stack() {
  constexpr std::size_t kBytes = 256 * 1024;
  unsigned char buf[kBytes];
  for (std::size_t i = 0; i < kBytes; i += 4096) buf[i] = 0;
  // Keeps the writes: the compiler must assume the asm reads the buffer.
  asm volatile("" : : "r"(buf) : "memory");
}

std::string errno_text(int err) { return std::string(std::strerror(err)); }

}  // namespace

const RealtimeStatus& PeriodicExecutive::prepare_realtime() {
  if (rt_.attempted) return rt_;
  rt_.attempted = true;
  if (!config_.realtime) return rt_;

  if (config_.priority > 0) {
    sched_param sp{};
    sp.sched_priority = config_.priority;
    const int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    if (err == 0) {
      rt_.sched_fifo = true;
    } else {
      rlimit rl{};
      getrlimit(RLIMIT_RTPRIO, &rl);
      rt_.warnings.push_back(
          "SCHED_FIFO priority " + std::to_string(config_.priority) + " refused (" +
          errno_text(err) + "; RLIMIT_RTPRIO is " +
          (rl.rlim_cur == RLIM_INFINITY ? std::string("unlimited") : std::to_string(rl.rlim_cur)) +
          "): run from the dualv systemd service (LimitRTPRIO=), or add '<user> - rtprio 99' to "
          "/etc/security/limits.d/dualv.conf. The loop runs with normal scheduling: timing is "
          "not guaranteed.");
    }
  }

  if (config_.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(static_cast<unsigned>(config_.cpu), &set);
    const int err = pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
    if (err == 0) {
      rt_.affinity_set = true;
    } else {
      rt_.warnings.push_back("pinning the loop to CPU " + std::to_string(config_.cpu) +
                             " refused (" + errno_text(err) +
                             "): check the CPU exists and is in the process's allowed set "
                             "(CPUAffinity= in the service, isolcpus= on the kernel command "
                             "line). The loop runs on any CPU.");
    }
  }

  if (config_.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      rt_.memory_locked = true;
    } else {
      const int err = errno;
      rlimit rl{};
      getrlimit(RLIMIT_MEMLOCK, &rl);
      rt_.warnings.push_back(
          "mlockall refused (" + errno_text(err) + "; RLIMIT_MEMLOCK is " +
          (rl.rlim_cur == RLIM_INFINITY ? std::string("unlimited")
                                        : std::to_string(rl.rlim_cur) + " bytes") +
          "): set LimitMEMLOCK=infinity in the service or '<user> - memlock unlimited' in "
          "/etc/security/limits.d/dualv.conf. Memory may be paged out during the run.");
    }
  }
  prefault_stack();
  return rt_;
}

void PeriodicExecutive::release_realtime() noexcept {
  if (!rt_.sched_fifo) return;
  sched_param sp{};
  sp.sched_priority = 0;
  pthread_setschedparam(pthread_self(), SCHED_OTHER, &sp);
  rt_.sched_fifo = false;
  rt_.attempted = false;
}

void PeriodicExecutive::begin() {
  prepare_realtime();
  stats_.reset();
  report_ = RunReport{};
  info_ = CycleInfo{};
  info_.period_ns = config_.period_ns;
  info_.stats = &stats_;
  info_.cycle = -1;
  release_ = clock_.now_ns();
  skipped_ = 0;
}

const CycleInfo& PeriodicExecutive::next() noexcept {
  clock_.sleep_until_ns(release_);
  const std::int64_t wake = clock_.now_ns();
  ++info_.cycle;
  info_.release_ns = release_;
  info_.wake_ns = wake;
  info_.lateness_ns = wake - release_;
  info_.skipped_releases = skipped_;
  info_.consecutive_misses = stats_.consecutive_misses();
  // The same clock twice is read once (each read is a syscall where there is no vDSO, as in
  // the user-mode-linux HIL guest).
  work_start_ = work_clock_ != nullptr && work_clock_ != &clock_ ? work_clock_->now_ns() : wake;
  return info_;
}

void PeriodicExecutive::done() noexcept {
  const std::int64_t end = clock_.now_ns();
  const std::int64_t work_end =
      work_clock_ != nullptr && work_clock_ != &clock_ ? work_clock_->now_ns() : end;
  stats_.record(info_.lateness_ns, work_end - work_start_, end - release_);
  ++report_.cycles;
  // Next release on the original grid; skip the ones this cycle ran past.
  const std::int64_t period = config_.period_ns;
  release_ += period;
  skipped_ = 0;
  if (end > release_) {
    skipped_ = (end - release_ + period - 1) / period;
    release_ += skipped_ * period;
    stats_.add_overruns(skipped_);
  }
}

RunReport PeriodicExecutive::end() noexcept {
  report_.stats = stats_.summary();
  return report_;
}

RunReport PeriodicExecutive::run_impl(Trampoline fn, void* ctx, std::int64_t max_cycles) {
  begin();
  bool stop_requested = false;
  for (std::int64_t cycle = 0; max_cycles <= 0 || cycle < max_cycles; ++cycle) {
    if (stop_.load(std::memory_order_relaxed)) {
      stop_requested = true;
      break;
    }
    const CycleResult result = fn(ctx, next());
    done();
    if (result == CycleResult::kStop) break;
  }
  RunReport report = end();
  report.stop_requested = stop_requested;
  // Consumed here rather than cleared at the start, so a stop requested while
  // the caller was still setting up (e.g. Ctrl-C) is not lost.
  stop_.store(false, std::memory_order_relaxed);
  return report;
}

}  // namespace dualv::control
