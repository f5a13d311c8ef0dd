#pragma once
// One real-time control cycle, in the order docs/architecture.md fixes:
//   drives -> read -> estimate -> reference -> control law -> safety -> write -> drives.
// The loop that runs it every period, from boot to shutdown, is control/loop/executor.hpp.
//
// Safety (safety/safety_filter.hpp) owns the final torque and DriveRequest: every command
// passes SafetyFilter::update() and is written through its WriteGuard. When the filter stops
// (SS1 or STO) the reference is abandoned (kStopped); after a reset the loop holds 0 N m with
// the drives disabled until a new reference is activated (a reset never restarts motion).
//
// The reference is a PreparedReference (prepared_reference.hpp) made ready off the real-time
// thread and taken with activate() at a cycle boundary; without one the cycle is idle: the
// estimator runs, the safety filter watches, 0 N m and disable voltage go to the drives.
// Phases: kIdle -> activate() -> kEnabling (zero torque, drives asked to enable; reference
// clock stopped) -> kRunning (the reference advances one period per cycle) -> kHolding (a
// program finished or a stream came to rest: the final pose is held by the same control law);
// deactivate() -> kIdle. A program is rebased on the robot's actual pose when prepared, so
// enabling never moves the robot.
//
// While a stream runs, the safety filter's command-stream watchdog is on
// (SafetyInput::streaming) and fed by every accepted setpoint (stream_setpoint); end_stream()
// is the normal end: the reference comes to rest and is held, the watchdog is off.
//
// step(), activate(), deactivate(), stream_setpoint() and end_stream() are noexcept and
// allocation-free. start() and start_streaming() are set-up conveniences (they read the drives,
// prepare a reference the cycle owns, and activate it; they may allocate and throw).
#include <cstdint>
#include <memory>
#include <optional>

#include "control/controller/controller.hpp"
#include "control/estimator/state_estimator.hpp"
#include "control/loop/prepared_reference.hpp"
#include "control/trajectory/limits.hpp"
#include "control/trajectory/program.hpp"
#include "control/trajectory/sequencer.hpp"
#include "control/trajectory/streaming_reference.hpp"
#include "drivers/actuator_set.hpp"
#include "safety/safety_filter.hpp"

namespace dualv::control {

// kStopped: the safety filter stopped the reference (SS1/STO) until it is deactivated.
// kIdle: no reference.
enum class CyclePhase : std::uint8_t { kEnabling = 0, kRunning, kHolding, kStopped, kIdle };
const char* to_string(CyclePhase p) noexcept;

enum class CycleStatus : std::uint8_t {
  kOk = 0,
  kIoError,         // the actuator set reported a bus error or stale data
  kEstimateFailed,  // forward kinematics failed: zero torque sent
  kControlFailed,   // reference or control law failed: zero torque sent
  kEnableTimeout,   // the drives did not reach Operation Enabled in time
  kSafetyStop,      // the safety filter is stopping or has stopped (record.safety says why)
  kNotActivated,    // activate() refused: a stop is latched or the feedback is invalid
};
const char* to_string(CycleStatus s) noexcept;

// One cycle's telemetry, plain fixed-size data (copied into the telemetry queue).
struct CycleRecord {
  std::int64_t cycle = 0;
  double t = 0.0;  // reference time [s]
  CyclePhase phase = CyclePhase::kIdle;
  CycleStatus status = CycleStatus::kOk;
  trajectory::Reference ref;         // X_d, q_d, lambda, segment ...
  StateEstimate est;                 // q, q_dot, X, X_dot
  ControlOutput control;             // tau*, tau_pd, tau_ff, errors, internal part
  drivers::ActuatorCommand command;  // what was written to the drives (after safety)
  drivers::ActuatorFeedback feedback;
  safety::SafetyReport safety;  // state, latched and new faults of this cycle
};

struct CycleConfig {
  double period = 1e-3;           // [s]
  double enable_timeout = 2.0;    // [s] to reach Operation Enabled on every drive
  safety::SafetyConfig safety{};  // the `safety:` section (defaults = config/dualv.yaml)
};

class ControlCycle {
 public:
  ControlCycle(const model::Model& model, const ControlSetup& setup, const CycleConfig& config);

  // RT: follow `ref` from the next step() on (it must outlive its use: deactivate() first).
  // Arms the safety filter unless it is operational already (a hold handing over to a
  // program: no re-enable, no torque dip), sets the controller switches, and starts in
  // kEnabling, or in kRunning when the filter was operational and every drive is enabled in
  // `feedback`. Refused (kLatched / kInvalidFeedback, nothing changed) while a stop is latched.
  safety::ArmStatus activate(PreparedReference& ref,
                             const drivers::ActuatorFeedback& feedback) noexcept;
  // RT: back to idle: no reference; an operational filter is disarmed (torque 0, drives
  // disabled). A latched stop stays latched.
  void deactivate() noexcept;
  PreparedReference* active() noexcept { return active_; }
  const PreparedReference* active() const noexcept { return active_; }

  // Set-up: reads the drives once, finds the plate pose by forward kinematics from home,
  // prepares `program` rebased onto it (owned by the cycle) and activates it. Throws
  // std::runtime_error with a message when the drives cannot be read, the pose cannot be
  // found, or a safety stop is still latched (reset it first).
  void start(drivers::ActuatorSet& io, const trajectory::Program& program,
             const trajectory::RebaseOptions& rebase);
  // Set-up, as start() but the reference follows streamed setpoints (streaming_reference.hpp)
  // from the robot's actual pose, at rest until the first one. Setpoints must lie in
  // `workspace`; `limits` bound the motion. Same errors as start().
  void start_streaming(drivers::ActuatorSet& io, const trajectory::StreamingLimits& limits,
                       const trajectory::Workspace& workspace);
  // RT: a setpoint for the running stream (the caller verified its signature and sequence).
  // Accepted ones feed the watchdog this cycle; refused ones (non-finite, outside the
  // workspace, no stream) change nothing and are counted by the reference.
  trajectory::TargetStatus stream_setpoint(const model::Pose& X) noexcept;
  // RT: the normal end of a stream (a signed stop): hold, watchdog off, no fault.
  void end_stream() noexcept;
  // A stream is followed and has not ended (end_stream) or stopped (safety).
  bool streaming() const noexcept {
    return active_ && active_->kind == ReferenceKind::kStream && active_->stream->active() &&
           phase_ != CyclePhase::kStopped;
  }
  const trajectory::StreamingReference* stream() const noexcept {
    return active_ && active_->stream ? &*active_->stream : nullptr;
  }

  CycleStatus step(drivers::ActuatorSet& io, CycleRecord& record) noexcept;

  CyclePhase phase() const noexcept { return phase_; }
  bool program_finished() const noexcept { return phase_ == CyclePhase::kHolding; }
  double program_duration() const noexcept;
  const trajectory::Sequencer* sequencer() const noexcept {
    return active_ && active_->sequencer ? &*active_->sequencer : nullptr;
  }
  // The estimator found the pose since start-up (the first cycles seed it from home).
  bool pose_known() const noexcept { return seeded_; }
  Controller& controller() noexcept { return controller_; }

  // The safety filter: stop/reset requests from any thread (safety().request_stop(...)),
  // its fault log (drained by a non-RT thread), its report.
  safety::SafetyFilter& safety() noexcept { return safety_; }
  const safety::SafetyFilter& safety() const noexcept { return safety_; }
  const safety::WriteGuard& write_guard() const noexcept { return guard_; }

  // Inputs for the next step()'s watchdogs (RT thread): the periodic executive's deadline
  // statistics (CycleInfo) and, in a streaming command mode, whether a command arrived.
  void note_timing(bool deadline_missed, int consecutive_misses) noexcept {
    deadline_missed_ = deadline_missed;
    consecutive_misses_ = consecutive_misses;
  }
  void note_command_stream(bool streaming, bool fresh) noexcept {
    streaming_ = streaming;
    stream_fresh_ = fresh;
  }

  // Fault injection for tests and `dualv selftest` only: called with the control law's
  // command (before the safety filter) so a test can make the controller misbehave
  // (10x torque, NaN). nullptr = none. Never set in a production run.
  using CommandHook = void (*)(void* context, std::int64_t cycle,
                               drivers::ActuatorCommand& command) noexcept;
  void set_command_hook(CommandHook hook, void* context) noexcept {
    hook_ = hook;
    hook_context_ = context;
  }

 private:
  CycleStatus finish(drivers::ActuatorSet& io, CycleRecord& rec,
                     drivers::IoStatus io_status) noexcept;
  // Set-up shared by start() and start_streaming(): the drives' feedback and the plate pose.
  void read_pose(drivers::ActuatorSet& io, drivers::ActuatorFeedback& fb, model::JointVector& q,
                 model::Pose& X);
  // Set-up: activates `ref` (then owned by the cycle) from the pose (q, X), or throws.
  void activate_owned(std::unique_ptr<PreparedReference> ref, const drivers::ActuatorFeedback& fb,
                      const model::JointVector& q, const model::Pose& X);
  // RT: the estimator's first pose, by forward kinematics from home.
  bool seed(const model::JointVector& q) noexcept;

  const model::Model* model_;
  CycleConfig config_;
  StateEstimator estimator_;
  Controller controller_;
  model::Data seed_data_;
  bool seeded_ = false;
  PreparedReference* active_ = nullptr;       // the reference followed (none: idle)
  std::unique_ptr<PreparedReference> owned_;  // start() / start_streaming() only
  CyclePhase phase_ = CyclePhase::kIdle;
  std::int64_t cycle_ = 0;
  std::int64_t enabling_cycles_ = 0;
  double t_ = 0.0;
  model::JointVector q_meas_;
  safety::SafetyFilter safety_;
  safety::WriteGuard guard_;
  bool deadline_missed_ = false;
  int consecutive_misses_ = 0;
  bool streaming_ = false;
  bool stream_fresh_ = false;
  CommandHook hook_ = nullptr;
  void* hook_context_ = nullptr;
};

}  // namespace dualv::control
