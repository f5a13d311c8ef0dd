#include "runtime/service_notifier.hpp"

#include <spdlog/spdlog.h>
#include <systemd/sd-daemon.h>

#include <utility>

namespace dualv::runtime {

namespace {

std::chrono::microseconds watchdog_from_environment() {
  std::uint64_t usec = 0;
  // > 0 only when WATCHDOG_USEC is set and WATCHDOG_PID (if set) is this process.
  if (sd_watchdog_enabled(0, &usec) > 0) return std::chrono::microseconds(usec);
  return std::chrono::microseconds(0);
}

void notify_systemd(const std::string& message) {
  const int r = sd_notify(0, message.c_str());
  // 0: not started by systemd (no NOTIFY_SOCKET), nothing to do.
  if (r < 0) spdlog::warn("sd_notify failed ({}): systemd does not hear from dualv", r);
}

// A status line is one line: a newline would start another notification field.
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

}  // namespace

ServiceNotifier::ServiceNotifier() : ServiceNotifier(watchdog_from_environment(), notify_systemd) {}

ServiceNotifier::ServiceNotifier(std::chrono::microseconds watchdog_interval, Sink sink)
    : interval_(watchdog_interval), sink_(std::move(sink)) {}

ServiceNotifier::~ServiceNotifier() { end_watch(); }

void ServiceNotifier::send(const std::string& message) {
  if (sink_) sink_(message);
}

void ServiceNotifier::ready(const std::string& status) {
  send("READY=1\nSTATUS=" + one_line(status));
  if (interval_.count() > 0 && !thread_.joinable()) thread_ = std::thread([this] { watch(); });
}

void ServiceNotifier::status(const std::string& status) { send("STATUS=" + one_line(status)); }

void ServiceNotifier::stopping(const std::string& status) {
  end_watch();
  send("STOPPING=1\nSTATUS=" + one_line(status));
}

void ServiceNotifier::end_watch() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void ServiceNotifier::watch() {
  const auto tick = interval_ / 4;
  // The first ping right away: READY=1 has just been sent, set-up was alive until now.
  std::uint64_t last = beats_.load(std::memory_order_relaxed);
  send("WATCHDOG=1");
  pings_.fetch_add(1, std::memory_order_relaxed);
  std::unique_lock<std::mutex> lock(mutex_);
  bool warned = false;
  while (!wake_.wait_for(lock, tick, [this] { return stop_; })) {
    const std::uint64_t now = beats_.load(std::memory_order_relaxed);
    if (now == last) {
      // Nothing called beat() for a whole tick: withhold the ping; systemd acts when the
      // interval passes without one. Said once per stall, in the journal.
      if (!warned)
        spdlog::warn("watchdog: no sign of life from the control loop for {} ms; not pinging",
                     std::chrono::duration_cast<std::chrono::milliseconds>(tick).count());
      warned = true;
      continue;
    }
    last = now;
    warned = false;
    send("WATCHDOG=1");
    pings_.fetch_add(1, std::memory_order_relaxed);
  }
}

}  // namespace dualv::runtime
