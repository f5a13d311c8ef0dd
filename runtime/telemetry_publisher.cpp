#include "runtime/telemetry_publisher.hpp"

#include <fmt/format.h>

#include <chrono>
#include <ctime>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <stdexcept>

#include "dualv_lcm/fault_event_t.hpp"
#include "dualv_lcm/loop_stats_t.hpp"
#include "dualv_lcm/robot_state_t.hpp"
#include "runtime/channels.hpp"

namespace dualv::runtime {

std::string log_url(const std::string& path) {
  // LCM's file provider takes the path after "file://"; an absolute path
  // keeps the log where the user asked even if the process changes directory.
  return "file://" + std::filesystem::absolute(path).string() + "?mode=w";
}

std::string default_log_path(const std::string& dir) {
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  localtime_r(&now, &local);
  char name[64];
  std::strftime(name, sizeof(name), "dualv-%Y%m%d-%H%M%S.lcmlog", &local);
  return (std::filesystem::path(dir) / name).string();
}

std::int64_t wall_utime() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000 + ts.tv_nsec / 1000;
}

namespace {
std::unique_ptr<lcm::LCM> open_lcm(const std::string& url) {
  auto l = std::make_unique<lcm::LCM>(url);
  if (!l->good())
    throw std::runtime_error(
        fmt::format("cannot open LCM URL '{}': for a log use file:///path/run.lcmlog?mode=w with a "
                    "writable directory; for live data use {}",
                    url, kLiveUrl));
  return l;
}

int check_decimation(int k) {
  if (k < 1)
    throw std::invalid_argument(fmt::format("telemetry state decimation must be >= 1 (got {})", k));
  return k;
}
}  // namespace

TelemetryPublisher::TelemetryPublisher(const std::string& url, int state_decimation)
    : owned_(open_lcm(url)),
      lcm_(owned_.get()),
      url_(url),
      decimation_(check_decimation(state_decimation)) {}

TelemetryPublisher::TelemetryPublisher(lcm::LCM& lcm, int state_decimation)
    : lcm_(&lcm), url_("(external)"), decimation_(check_decimation(state_decimation)) {}

TelemetryPublisher::~TelemetryPublisher() { stop(); }

void TelemetryPublisher::start(int poll_ms) {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this, poll_ms] {
    // Polling rather than a condition variable: the RT producer must never
    // touch a lock or make a syscall to wake us.
    while (running_.load(std::memory_order_acquire)) {
      drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(poll_ms));
    }
  });
}

void TelemetryPublisher::stop() {
  if (running_.exchange(false) && thread_.joinable()) thread_.join();
  drain();  // whatever the loop queued last (the final loop_stats) still goes out
}

std::size_t TelemetryPublisher::drain() {
  std::size_t published = 0;
  Event e;
  // Events first: a fault should reach the log before the states that follow it.
  while (events_.try_pop(e)) {
    publish_event(e);
    ++published;
  }
  StateSample s;
  while (states_.try_pop(s)) {
    if (state_seen_++ % static_cast<std::uint64_t>(decimation_) != 0) continue;
    publish_state(s);
    ++published;
  }
  return published;
}

TelemetryCounters TelemetryPublisher::counters() const noexcept {
  TelemetryCounters c;
  c.states = n_states_.load();
  c.faults = n_faults_.load();
  c.loop_stats = n_stats_.load();
  c.states_dropped = states_.dropped();
  c.events_dropped = events_.dropped();
  c.publish_errors = n_errors_.load();
  return c;
}

namespace {
template <typename Array>
std::vector<double> first_n(const Array& a, int n) {
  n = std::clamp(n, 0, static_cast<int>(a.size()));
  return std::vector<double>(a.begin(), a.begin() + n);
}
}  // namespace

void TelemetryPublisher::publish_state(const StateSample& s) {
  dualv_lcm::robot_state_t m;
  m.utime = s.utime != 0 ? s.utime : wall_utime();
  m.cycle = s.cycle;
  m.t = s.t;
  const int n = std::clamp<int>(s.n, 0, kMaxJoints);
  m.n = static_cast<std::int16_t>(n);
  m.q = first_n(s.q, n);
  m.q_dot = first_n(s.q_dot, n);
  m.tau_cmd = first_n(s.tau_cmd, n);
  m.tau_internal = first_n(s.tau_internal, n);
  for (int i = 0; i < 3; ++i) {
    m.X[i] = s.X[i];
    m.X_d[i] = s.X_d[i];
    m.tracking_error[i] = s.tracking_error[i];
  }
  m.lambda = s.lambda;
  m.segment = s.segment;
  m.safety_state = s.safety_state;
  m.safety_text = s.safety_text;
  m.status_flags = s.status_flags;
  for (int i = 0; i < 3; ++i) m.stream_target[i] = s.stream_target[i];
  m.stream_age = s.stream_age;
  m.stream_accepted = s.stream_accepted;
  m.stream_refused = s.stream_refused;
  if (dropped() > 0) m.status_flags |= dualv_lcm::robot_state_t::FLAG_TELEMETRY_DROPPED;
  if (lcm_->publish(kStateChannel, &m) == 0)
    n_states_.fetch_add(1);
  else
    n_errors_.fetch_add(1);
}

void TelemetryPublisher::publish_event(const Event& e) {
  if (const auto* f = std::get_if<FaultSample>(&e)) {
    dualv_lcm::fault_event_t m;
    m.utime = f->utime != 0 ? f->utime : wall_utime();
    m.cycle = f->cycle;
    m.cause = f->cause;
    m.reaction = f->reaction;
    m.node = f->node;
    m.detection_latency_cycles = f->detection_latency_cycles;
    const int n = std::clamp<int>(f->n, 0, kMaxJoints);
    m.n = static_cast<std::int16_t>(n);
    m.tau_at_detection = first_n(f->tau_at_detection, n);
    m.text = f->text;
    if (lcm_->publish(kFaultChannel, &m) == 0)
      n_faults_.fetch_add(1);
    else
      n_errors_.fetch_add(1);
    return;
  }
  const auto& l = std::get<LoopStatsSample>(e);
  const control::LoopStatsSummary& s = l.stats;
  dualv_lcm::loop_stats_t m;
  m.utime = l.utime != 0 ? l.utime : wall_utime();
  m.period_ns = s.period_ns;
  m.deadline_ns = s.deadline_ns;
  m.cycles = s.cycles;
  m.resolution_ns = s.resolution_ns;
  m.cycle_min_ns = s.cycle.min_ns;
  m.cycle_median_ns = s.cycle.median_ns;
  m.cycle_p99_ns = s.cycle.p99_ns;
  m.cycle_p999_ns = s.cycle.p999_ns;
  m.cycle_max_ns = s.cycle.max_ns;
  m.lateness_min_ns = s.lateness.min_ns;
  m.lateness_median_ns = s.lateness.median_ns;
  m.lateness_p99_ns = s.lateness.p99_ns;
  m.lateness_p999_ns = s.lateness.p999_ns;
  m.lateness_max_ns = s.lateness.max_ns;
  m.deadline_misses = s.deadline_misses;
  m.overruns = s.overruns;
  m.consecutive_misses = s.consecutive_misses;
  m.max_consecutive_misses = s.max_consecutive_misses;
  m.telemetry_dropped =
      l.telemetry_dropped != 0 ? l.telemetry_dropped : static_cast<std::int64_t>(dropped());
  m.realtime = l.realtime;
  if (lcm_->publish(kLoopStatsChannel, &m) == 0)
    n_stats_.fetch_add(1);
  else
    n_errors_.fetch_add(1);
}

}  // namespace dualv::runtime
