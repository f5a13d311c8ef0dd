#pragma once
// Receives operator commands on the LCM command channel and streamed pose
// setpoints on the setpoint channel, verifies them (command_auth.hpp) and hands
// the accepted ones to the application through lock-free queues, so the
// consumer may be the real-time loop itself. Refused commands and setpoints
// are counted and logged, never queued. Anything a peer can trigger at will (refused
// commands, refused setpoints, accepted unsigned e-stops, a full queue) is logged through a
// LogLimiter (log_limiter.hpp): the first kLogBurst in full, then one summary line per
// second with the counts (issue 14: 2000 garbage messages are not 2000 log lines).
//
// E-stops are also counted in an atomic the consumer can poll: an e-stop is
// never lost, even when the queue is full.
//
// Threads: poll() (or the thread start() runs) is the producer; try_pop() and
// estop_requests() belong to the one consumer thread.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>

#include <lcm/lcm.h>

#include "common/spsc_queue.hpp"
#include "runtime/command_auth.hpp"
#include "runtime/log_limiter.hpp"

namespace lcm {
class LCM;
}  // namespace lcm

namespace dualv::runtime {

// A verified command, fixed-size and trivially copyable for the queue.
struct VerifiedCommand {
  CommandKind kind = CommandKind::kStop;
  std::int64_t utime = 0;
  std::int64_t sequence = 0;
  bool is_signed = false;
  char program[65] = {};
  char key_id[65] = {};
};

// A verified pose setpoint (setpoint_t), fixed-size for the queue.
struct VerifiedSetpoint {
  std::int64_t utime = 0;
  std::int64_t sequence = 0;
  double x = 0.0, y = 0.0, theta = 0.0;
};

class CommandChannel {
 public:
  static constexpr std::size_t kQueue = 64;
  static constexpr std::uint64_t kLogBurst = 10;              // lines in full per kind ...
  static constexpr std::int64_t kLogInterval_us = 1'000'000;  // ... then a summary per second
  using WallClock = std::function<std::int64_t()>;            // us since 1970
  // The application's own check of a signed setpoint (workspace, kinematics): an empty
  // string accepts it, otherwise the reason it is refused. Runs on the receiving thread.
  using SetpointCheck = std::function<std::string(double x, double y, double theta)>;

  // Opens its own LCM on `url` (throws std::runtime_error when it cannot).
  CommandChannel(const std::string& url, CommandVerifier verifier, WallClock clock = {});
  // Uses an LCM instance owned by the caller (tests with memq://).
  CommandChannel(lcm::LCM& lcm, CommandVerifier verifier, WallClock clock = {});
  ~CommandChannel();
  CommandChannel(const CommandChannel&) = delete;
  CommandChannel& operator=(const CommandChannel&) = delete;

  // Handles whatever arrives within timeout_ms; returns messages handled
  // (0 on timeout, < 0 on an LCM error). Not while the thread runs.
  int poll(int timeout_ms);
  void start();  // a thread calling poll(50) until stop()
  void stop();

  // Set before start() (or the first poll()).
  void set_setpoint_check(SetpointCheck check) { setpoint_check_ = std::move(check); }

  bool try_pop(VerifiedCommand& out) noexcept { return queue_.try_pop(out); }
  bool try_pop_setpoint(VerifiedSetpoint& out) noexcept { return setpoints_.try_pop(out); }
  std::uint64_t setpoints_accepted() const noexcept { return sp_accepted_.load(); }
  std::uint64_t setpoints_refused() const noexcept { return sp_refused_.load(); }
  std::uint64_t setpoints_dropped() const noexcept { return setpoints_.dropped(); }
  std::uint64_t estop_requests() const noexcept { return estops_.load(std::memory_order_acquire); }
  // The same count for a watcher on another thread (control::Executor::watch_estops).
  const std::atomic<std::uint64_t>& estop_counter() const noexcept { return estops_; }
  std::uint64_t accepted() const noexcept { return accepted_.load(); }
  std::uint64_t refused() const noexcept { return refused_.load(); }
  std::uint64_t dropped() const noexcept { return queue_.dropped(); }
  // Verdict counts; read them from the thread that polls (or after stop()).
  const CommandVerifier& verifier() const noexcept { return verifier_; }

 private:
  void subscribe();
  // Subscribed through LCM's C API: the C++ wrapper's member-function
  // subscription miscompiles under GCC 12's -fsanitize=vptr (the callback
  // receives a wrong user_data), which would break sanitizer CI runs.
  static void on_message(const lcm_recv_buf_t* rbuf, const char* channel, void* self);
  static void on_setpoint(const lcm_recv_buf_t* rbuf, const char* channel, void* self);
  void handle(const void* data, std::size_t size);
  void handle_setpoint(const void* data, std::size_t size);

  std::unique_ptr<lcm::LCM> owned_;
  lcm::LCM* lcm_;
  lcm_subscription_t* subscription_ = nullptr;
  lcm_subscription_t* setpoint_subscription_ = nullptr;
  SetpointCheck setpoint_check_;
  SpscQueue<VerifiedSetpoint, kQueue> setpoints_;
  std::atomic<std::uint64_t> sp_accepted_{0}, sp_refused_{0};
  CommandVerifier verifier_;
  WallClock clock_;
  SpscQueue<VerifiedCommand, kQueue> queue_;
  std::atomic<std::uint64_t> estops_{0}, accepted_{0}, refused_{0};
  std::atomic<bool> running_{false};
  std::thread thread_;
  // Touched only by the thread that polls (the LCM callbacks), and by stop() after it.
  void log_summaries(std::int64_t now_us, bool force);
  LogLimiter refused_log_{kLogBurst, kLogInterval_us};
  LogLimiter accepted_log_{kLogBurst, kLogInterval_us};
  LogLimiter queue_full_log_{kLogBurst, kLogInterval_us};
  LogLimiter setpoint_log_{kLogBurst, kLogInterval_us};
};

// Sends one pose setpoint (signed when `key` is given) on the setpoint channel
// with `sequence` and the wall clock as utime. Throws std::runtime_error when
// LCM cannot publish.
dualv_lcm::setpoint_t send_setpoint(lcm::LCM& lcm, double x, double y, double theta,
                                    std::int64_t sequence, const CommandKey* key);

// Sends one command (signed when `key` is given) on the command channel;
// sequence and utime come from the wall clock in microseconds, which keeps
// them increasing across separate CLI invocations. Returns the command sent.
// Throws std::runtime_error when LCM cannot publish.
dualv_lcm::command_t send_command(lcm::LCM& lcm, CommandKind kind, const std::string& program,
                                  const CommandKey* key);

}  // namespace dualv::runtime
