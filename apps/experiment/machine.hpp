#pragma once
// The machine of one dualv process: its drives (the in-process simulation or CANopen drives
// on a bus), the one control loop that owns them from start() to shutdown()
// (control/loop/executor.hpp), and what leaves the loop: telemetry (every cycle while the
// robot moves, 50 Hz idle), the fault log, the rows of the program being recorded. The
// supervisor's verbs (run a program, follow a stream, serve) are its members; they are not
// real-time and run on the thread that calls them (docs/architecture.md).
//
// Three ways to keep time (MachineOptions::pacing):
//   - kSimulated (in-process simulation only): the caller's thread steps the loop on simulated
//     time, as fast as the CPU allows: deterministic;
//   - kLoopThread: the loop runs on its own real-time thread (control/loop/loop_thread.hpp) at
//     the configured rate; the caller's thread supervises;
//   - kCallerThread: the caller's thread runs the loop at the configured rate, a cycle per
//     pump() (`dualv selftest --can`, whose scenarios inject faults cycle by cycle); it gets
//     SCHED_FIFO while the loop runs and normal scheduling back at shutdown().
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "apps/experiment/closed_loop.hpp"
#include "control/loop/executor.hpp"
#include "control/loop/loop_thread.hpp"
#include "drivers/canopen/cycle_clock.hpp"
#include "sim/plant.hpp"

namespace dualv::apps {

// The drives as the machine sees them before they are booted: nothing to read or write until
// attach() hands over the booted ones (so the machine's set-up happens before the boot).
class DrivesToCome final : public drivers::ActuatorSet {
 public:
  explicit DrivesToCome(int n) : n_(n) {}
  void attach(drivers::ActuatorSet& drives) noexcept { inner_ = &drives; }
  int size() const noexcept override { return n_; }
  drivers::IoStatus read(drivers::ActuatorFeedback& fb) noexcept override {
    return inner_ ? inner_->read(fb) : drivers::IoStatus::kNotReady;
  }
  drivers::IoStatus write(const drivers::ActuatorCommand& c) noexcept override {
    return inner_ ? inner_->write(c) : drivers::IoStatus::kNotReady;
  }

 private:
  int n_;
  drivers::ActuatorSet* inner_ = nullptr;
};

enum class Pacing : std::uint8_t { kSimulated = 0, kLoopThread, kCallerThread };

struct MachineOptions {
  Pacing pacing = Pacing::kSimulated;
  runtime::TelemetryPublisher* telemetry = nullptr;  // robot states, faults, loop statistics
  runtime::CommandChannel* commands = nullptr;       // e-stop counter, stop/reset, setpoints
  runtime::ServiceNotifier* service = nullptr;       // beat() every cycle (systemd watchdog)
  std::string fault_log_path;                        // JSON lines, written off the RT thread
  // kCallerThread: the caller already locked the process's memory (mlockall) before the
  // drives booted, so the loop's set-up does not do it again between priming and cycle 0.
  bool memory_locked = false;
  // Called from start() with what the real-time set-up obtained (paced machines).
  std::function<void(const control::RealtimeStatus&)> on_realtime;
  // The CANopen drives' clock (drivers/canopen/cycle_clock.hpp), stamped with each cycle's
  // wake-up; only for a loop paced on the monotonic clock (the clock `io` reads outside cycles).
  drivers::canopen::CycleClock* cycle_clock = nullptr;
};

class Machine {
 public:
  // `io` must outlive the machine; `plant`, when given, is the simulation behind `io`,
  // advanced one period after every write (inside the cycle).
  // A paced machine runs its loop on `launched` when given (a LoopThread launched before the
  // drives booted), else on a thread of its own.
  Machine(const RobotConfig& config, drivers::ActuatorSet& io, const MachineOptions& options,
          sim::Plant* plant = nullptr, std::unique_ptr<control::LoopThread> launched = nullptr);
  ~Machine();  // shutdown()
  Machine(const Machine&) = delete;
  Machine& operator=(const Machine&) = delete;

  // Starts the loop (paced: its thread; stepped: one idle cycle, so the pose is known).
  // Registers the machine for SIGINT/SIGTERM (install_stop_signal_handlers).
  void start();
  // Runs `program` with the variant's timing law and controller switches from the robot's
  // actual pose, and returns when it ended (finished + settle, or stopped with torque off).
  RunResult run(const trajectory::Program& program, const Variant& variant,
                const RunOptions& options = {});
  // Starts `program` as run() does and returns its reference id at once (the caller pumps
  // and watches the loop itself). Throws when the loop refuses it.
  // `rebased`, when given, receives the program as the loop follows it.
  std::uint64_t begin(const trajectory::Program& program, const Variant& variant,
                      double settle_time, trajectory::Program* rebased = nullptr);
  // Follows the stream of signed setpoints from options.commands (needs it) until a signed
  // stop (hold for settle_time) or a safety stop, or max_stream_time.
  RunResult stream(const RunOptions& options);
  // Ends the loop: a moving robot is stopped first (SS1); the drives are left disabled.
  // Returns the loop's report. Idempotent.
  control::RunReport shutdown();

  // The supervisor's view: one cycle (stepped) or ~5 ms (paced); drains the loop's rows
  // (kept only for the program being recorded) and collects retired references.
  void pump();
  control::Executor& executor() noexcept { return *executor_; }
  control::LoopSnapshot snapshot() const noexcept { return executor_->snapshot(); }
  bool paced() const noexcept { return options_.pacing != Pacing::kSimulated; }
  // The plant failed (stepped and paced): the simulation is no longer valid.
  bool plant_failed() const noexcept;
  std::string plant_failure() const;
  // The loop's timing so far (stepped: also while it runs; paced: after shutdown()).
  control::LoopStatsSummary loop_stats() const;
  std::uint64_t setpoints_ignored() const noexcept;
  // Paced: the first cycle's wake-up on the monotonic clock [ns] (0 before start()).
  std::int64_t first_cycle_ns() const noexcept {
    return thread_ ? thread_->first_cycle_ns() : first_ns_;
  }

 private:
  class Hooks;
  class Drain;
  // RunOptions::before_cycle for the duration of one run() / stream().
  struct BeforeCycleScope {
    BeforeCycleScope(Machine& m, std::function<void(std::int64_t)> fn) : m_(m) {
      m_.before_cycle_ = std::move(fn);
    }
    ~BeforeCycleScope() {
      m_.before_cycle_ = nullptr;
      m_.before_base_ = -1;
    }
    Machine& m_;
  };
  // Prepares and starts a reference; retries while the robot moved since the preparation.
  // Returns its id; throws with the reason when the loop refuses it.
  std::uint64_t take(
      const std::function<std::unique_ptr<control::PreparedReference>(std::uint64_t epoch)>&
          prepare);
  RunResult follow(std::uint64_t id, const trajectory::Program& program, double duration,
                   const Variant& variant, const RunOptions& options, bool stream);

  const RobotConfig& config_;
  drivers::ActuatorSet& io_;
  MachineOptions options_;
  sim::Plant* plant_;
  std::unique_ptr<Hooks> hooks_;
  std::unique_ptr<Drain> drain_;
  std::unique_ptr<control::Executor> executor_;
  // Stepped: the executive in pull form on simulated time. Paced: the loop thread.
  control::SimClock sim_clock_;
  control::MonotonicClock mono_;
  std::unique_ptr<control::PeriodicExecutive> stepper_;
  std::unique_ptr<control::LoopThread> thread_;
  std::function<void(std::int64_t)> before_cycle_;  // RunOptions::before_cycle (stepped)
  std::int64_t before_base_ = -1;                   // its cycle 0 on the loop's count
  bool started_ = false;
  bool ended_ = false;  // the loop returned (stepped)
  bool shut_down_ = false;
  std::int64_t first_ns_ = 0;  // stepped: the first cycle's wake-up on the loop clock
  control::RunReport report_;
};

}  // namespace dualv::apps
