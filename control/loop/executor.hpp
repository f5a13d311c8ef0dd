#pragma once
// The one real-time loop of a dualv process (docs/architecture.md): started once the drives
// are booted, it runs a ControlCycle every period until shutdown, so SYNC, RPDOs and the host
// heartbeat never stop while the process lives. What changes is its mode:
//
//   kIdle     no reference: 0 N m, drives disabled (the safety filter's kDisabled)
//   kProgram  a prepared program is followed
//   kStream   streamed setpoints are followed
//   kHold     after a normal end with `loop.idle: hold`: the final pose is held, drives enabled
//   kSafeStop the safety filter is stopping (SS1) or has stopped (STO): a reset is needed
//
// Switching is in two phases (ros2_control's prepare / perform): a supervisor thread prepares
// a reference off the real-time thread (prepare_program / prepare_stream: loaded, pre-flighted,
// rebased on the pose this loop reports) and hands it over with start(); the loop takes it at
// a cycle boundary, or refuses it (an event says why). Stop, end-of-stream, reset and shutdown
// travel through the same lock-free queue. E-stops never queue: request_estop() (any thread,
// async-signal-safe) and a watched counter (e.g. the command channel's) latch a stop in the
// safety filter in whatever phase the loop is, and a reference asked for before an e-stop is
// refused at take-over (PreparedReference::estop_epoch): a program being prepared when the
// e-stop came never starts. Leaving idle never moves the robot: a start enables the drives at
// 0 N m and follows a reference that begins at the actual pose.
//
// Threads: step() is the real-time thread's (noexcept, no allocation, no lock, no print);
// the supervisor functions belong to one other thread; request_estop() and the observers'
// reads of snapshot() may come from anywhere. Events and retired references leave the loop
// through lock-free queues; LoopHooks (telemetry, recording, a simulated plant) run inside
// the cycle and must keep its rules.
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "common/seqlock.hpp"
#include "common/spsc_queue.hpp"
#include "control/loop/control_cycle.hpp"
#include "control/loop/periodic_executive.hpp"
#include "control/loop/prepared_reference.hpp"

namespace dualv::control {

enum class LoopMode : std::uint8_t { kIdle = 0, kProgram, kStream, kHold, kSafeStop };
const char* to_string(LoopMode m) noexcept;

// What the loop does when nothing is followed (the `loop.idle` key): kDisabled = drives
// disabled at 0 N m; kHold = after a program or stream ends normally the final pose is held.
// At start-up and after any stop the drives stay disabled until a start: nothing enables by
// itself.
enum class IdleMode : std::uint8_t { kDisabled = 0, kHold };
const char* to_string(IdleMode m) noexcept;

struct ExecutorConfig {
  CycleConfig cycle;
  IdleMode idle = IdleMode::kDisabled;
  // A start is refused when the robot moved more than this since the pose its reference was
  // prepared on (the supervisor prepares again): [m] in x, y and [rad] in theta.
  double takeover_position = 2e-4;
  double takeover_angle = 2e-3;
};

enum class RefuseReason : std::uint8_t {
  kNone = 0,
  kEstop,         // an e-stop came while the reference was prepared
  kLatched,       // a stop is latched: reset first
  kBusy,          // a program or stream is being followed
  kMoved,         // the robot is no longer at the pose the reference was prepared on
  kNoPose,        // the loop has no valid pose (forward kinematics failed)
  kShuttingDown,  // the loop is ending
  kInvalid,       // not a program or a stream, or the feedback is not finite
};
const char* to_string(RefuseReason r) noexcept;

struct LoopCommand {
  enum class Kind : std::uint8_t { kStart = 0, kStop, kEndStream, kReset, kShutdown };
  Kind kind = Kind::kStop;
  PreparedReference* reference = nullptr;  // kStart: owned by the loop from the push on
};

// What the loop tells the supervisor (never lost while the supervisor drains the queue).
struct LoopEvent {
  enum class Kind : std::uint8_t {
    kStarted = 0,   // a reference was taken (id)
    kRefused,       // a reference was refused (id, reason); it never moved anything
    kFinished,      // a reference ended normally (program end + settle, stream stopped + settle)
    kStopped,       // the safety filter stopped (SS1/STO begun); id: the reference, 0 idle
    kTorqueOff,     // the stop reached torque off (STO)
    kReset,         // a reset was accepted: idle, drives disabled
    kResetRefused,  // a reset was refused: latched = the causes still active
    kLoopEnded,     // shutdown complete: the loop returns
  };
  Kind kind = Kind::kStarted;
  std::uint64_t id = 0;
  std::int64_t cycle = 0;
  double t = 0.0;  // reference time [s]
  RefuseReason reason = RefuseReason::kNone;
  CycleStatus status = CycleStatus::kOk;  // kStopped: the cycle's status
  std::uint32_t latched = 0;              // kStopped / kTorqueOff: safety::FaultSet
};

// The loop's latest state for the supervisor and observers (a seqlock copy, any thread).
struct LoopSnapshot {
  model::Pose pose() const noexcept { return {X[0], X[1], X[2]}; }
  std::int64_t cycle = -1;  // -1: the loop has not run yet
  LoopMode mode = LoopMode::kIdle;
  CyclePhase phase = CyclePhase::kIdle;
  safety::SafetyState safety = safety::SafetyState::kDisabled;
  std::uint32_t latched = 0;  // safety::FaultSet
  bool pose_valid = false;
  double X[3] = {0.0, 0.0, 0.0};  // estimated plate pose x [m], y [m], theta [rad]
  double t = 0.0;                 // reference time [s]
  double duration = 0.0;          // the program's duration [s] (0: none)
  std::uint64_t reference = 0;    // id followed (0: none)
  std::uint64_t estops_seen = 0;  // e-stops the loop latched
  // The last stream followed: setpoints its reference took and refused (kept after its end).
  std::uint64_t stream_accepted = 0, stream_refused = 0;
};

class Executor;

// Called inside the cycle (real-time rules: noexcept, no allocation, no lock, no print).
class LoopHooks {
 public:
  virtual ~LoopHooks() = default;
  // After the commands were taken, before the cycle: e.g. streamed setpoints.
  virtual void before_cycle(Executor&, const CycleInfo&) noexcept {}
  // After the write: telemetry, recording, a simulated plant's step.
  virtual void after_cycle(const Executor&, const CycleRecord&, const CycleInfo&) noexcept {}
};

class Executor {
 public:
  static constexpr std::size_t kQueue = 64;

  // Set-up. `io` is the drives (booted) and must outlive the executor.
  Executor(const model::Model& model, const ControlSetup& setup, const ExecutorConfig& config,
           drivers::ActuatorSet& io);
  ~Executor();
  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;

  // --- set-up, before the loop runs ------------------------------------------------------
  void set_hooks(LoopHooks* hooks) noexcept { hooks_ = hooks; }
  // An e-stop counter to watch (e.g. runtime::CommandChannel's): every increment latches an
  // e-stop (StopSource::kLcm). Counts made before the loop runs latch at its first cycle.
  void watch_estops(const std::atomic<std::uint64_t>* counter) noexcept { watched_ = counter; }

  // --- the supervisor thread -------------------------------------------------------------
  // The e-stops counted so far; read it when a start is asked for and put it in the
  // reference (prepare_* do), so one that comes during preparation refuses the start.
  std::uint64_t estop_epoch() const noexcept;
  // References rebased on the pose the loop reports (throws std::runtime_error when the loop
  // has none yet, or as prepared_reference.hpp says). `epoch`: estop_epoch() when the start
  // was asked for.
  std::unique_ptr<PreparedReference> prepare_program(const trajectory::Program& program,
                                                     const trajectory::RebaseOptions& rebase,
                                                     std::uint64_t epoch);
  std::unique_ptr<PreparedReference> prepare_stream(const trajectory::StreamingLimits& limits,
                                                    const trajectory::Workspace& workspace,
                                                    std::uint64_t epoch);
  // Hands a prepared reference to the loop; returns its id (> 0), or 0 when the queue is
  // full (the reference is freed).
  std::uint64_t start(std::unique_ptr<PreparedReference> reference);
  // Stop (a program: SS1; a stream: as kEndStream), end a stream normally, reset a stop,
  // shut down (a running reference is stopped first). False when the queue is full.
  bool submit(LoopCommand::Kind kind) noexcept;
  bool poll_event(LoopEvent& event) noexcept { return events_.try_pop(event); }
  // Frees the references the loop is done with. Call it now and then.
  void collect();
  LoopSnapshot snapshot() const noexcept { return snapshot_.read(); }

  // --- any thread --------------------------------------------------------------------------
  void request_estop(safety::StopSource source) noexcept;

  // --- the real-time thread ----------------------------------------------------------------
  // One cycle: e-stops, commands, ControlCycle::step, mode changes, hooks, snapshot. kStop
  // once a shutdown is complete (torque off).
  CycleResult step(const CycleInfo& info) noexcept;

  // The cycle, its safety filter and record (RT thread, or after the loop ended; fault
  // injection by `dualv selftest`).
  ControlCycle& cycle() noexcept { return cycle_; }
  const ControlCycle& cycle() const noexcept { return cycle_; }
  safety::SafetyFilter& safety() noexcept { return cycle_.safety(); }
  const CycleRecord& record() const noexcept { return rec_; }
  drivers::ActuatorSet& io() noexcept { return *io_; }
  LoopMode mode() const noexcept { return mode_; }
  // The reference this cycle followed (0: none), also in the cycle that ended it.
  std::uint64_t reference_id() const noexcept { return cycle_reference_; }
  // RT: a streamed setpoint for the stream being followed (LoopHooks::before_cycle).
  trajectory::TargetStatus stream_setpoint(const model::Pose& X) noexcept {
    return cycle_.stream_setpoint(X);
  }
  const ExecutorConfig& config() const noexcept { return config_; }
  // Fault injection for `dualv selftest` only: from the next step() on, the safety filter is
  // told this many consecutive deadline misses (0: the executive's own figures). Never set
  // in a production run.
  void inject_deadline_misses(int consecutive) noexcept { injected_misses_ = consecutive; }
  std::uint64_t events_dropped() const noexcept { return events_.dropped(); }

 private:
  void take_commands() noexcept;
  void take_start(PreparedReference* ref) noexcept;
  void after_step() noexcept;
  void end_reference(bool finished) noexcept;
  void retire(PreparedReference* ref) noexcept;
  void emit(LoopEvent::Kind kind, std::uint64_t id,
            RefuseReason reason = RefuseReason::kNone) noexcept;
  std::uint64_t current_epoch() const noexcept;

  const model::Model* model_;
  ExecutorConfig config_;
  drivers::ActuatorSet* io_;
  ControlCycle cycle_;
  CycleRecord rec_;
  LoopHooks* hooks_ = nullptr;
  const std::atomic<std::uint64_t>* watched_ = nullptr;
  std::uint64_t watched_seen_ = 0;
  std::atomic<std::uint64_t> own_estops_{0};
  SpscQueue<LoopCommand, kQueue> commands_;
  SpscQueue<LoopEvent, 256> events_;
  SpscQueue<PreparedReference*, kQueue> retired_;
  SeqLock<LoopSnapshot> snapshot_;
  std::unique_ptr<PreparedReference> hold_;  // kHold's reference, made at set-up
  std::uint64_t next_id_ = 1;                // supervisor
  LoopMode mode_ = LoopMode::kIdle;
  bool shutting_down_ = false;
  bool torque_off_reported_ = false;
  bool reset_waiting_ = false;  // a reset was forwarded to the filter: report its outcome
  std::int64_t settle_cycles_ = 0;
  int injected_misses_ = 0;
  std::uint64_t cycle_reference_ = 0;
  std::uint64_t stream_accepted_ = 0, stream_refused_ = 0;
};

}  // namespace dualv::control
