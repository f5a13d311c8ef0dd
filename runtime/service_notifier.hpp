#pragma once
// systemd service notification for `dualv run` (dualv.service is Type=notify with
// WatchdogSec=): READY=1 once set-up is done, STATUS= lines saying what the robot does,
// STOPPING=1 on the way out, and WATCHDOG=1 pings that prove the process is still working.
//
// The watchdog pings only while something proves liveness by calling beat(): the real-time
// loop once per cycle, the --serve loop once per poll while it waits for commands. A thread
// of this class checks the beat counter every quarter of the watchdog interval and pings
// only when it moved since the last check, so a hung loop stops the pings and systemd kills
// the service (the drives then stop on their own: heartbeat consumer, RPDO deadline).
// Pinging every quarter interval (systemd suggests half) tolerates a stall of 3/4 of the
// interval on a loaded machine before a ping is missed.
//
// Uses libsystemd (sd_notify, sd_watchdog_enabled). Outside systemd (no NOTIFY_SOCKET)
// every call does nothing; without WATCHDOG_USEC no watchdog thread runs.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace dualv::runtime {

class ServiceNotifier {
 public:
  // Receives one notification ("READY=1\nSTATUS=..."); the default is sd_notify.
  using Sink = std::function<void(const std::string& message)>;

  // From the environment: NOTIFY_SOCKET, WATCHDOG_USEC and WATCHDOG_PID (sd_watchdog_enabled).
  ServiceNotifier();
  // For tests: this watchdog interval (zero: none) and this sink instead of sd_notify.
  ServiceNotifier(std::chrono::microseconds watchdog_interval, Sink sink);
  ~ServiceNotifier();
  ServiceNotifier(const ServiceNotifier&) = delete;
  ServiceNotifier& operator=(const ServiceNotifier&) = delete;

  // Zero when systemd asked for no watchdog.
  std::chrono::microseconds watchdog_interval() const noexcept { return interval_; }

  // READY=1 with a status line; starts the watchdog thread (when there is a watchdog).
  void ready(const std::string& status);
  void status(const std::string& status);
  // STOPPING=1 with a status line; the watchdog thread ends (systemd stops watching too).
  void stopping(const std::string& status);

  // Proof of life, from the real-time thread: lock-free, no syscall, no allocation.
  void beat() noexcept { beats_.fetch_add(1, std::memory_order_relaxed); }
  // WATCHDOG=1 pings sent so far.
  std::uint64_t pings() const noexcept { return pings_.load(std::memory_order_relaxed); }

 private:
  void send(const std::string& message);
  void watch();
  void end_watch();

  std::chrono::microseconds interval_{0};
  Sink sink_;
  std::atomic<std::uint64_t> beats_{0};
  static_assert(std::atomic<std::uint64_t>::is_always_lock_free);
  std::atomic<std::uint64_t> pings_{0};
  std::mutex mutex_;  // the watchdog thread's wake-up; never taken by the real-time thread
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace dualv::runtime
