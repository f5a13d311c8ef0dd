#pragma once
// One real-time control cycle, in the order DESIGN.md fixes:
//   drives -> read -> estimate -> reference -> control law -> safety -> write -> drives.
//
// Safety (safety/safety_filter.hpp) owns the final torque and DriveRequest: every command
// passes SafetyFilter::update() and is written through its WriteGuard. When the filter stops
// (SS1 or STO) the program is abandoned (kStopped); after a reset the loop holds 0 N m with
// the drives disabled until start() is called again (a reset never restarts motion).
//
// Phases: kEnabling (zero torque, drives asked to enable; program clock stopped) ->
// kRunning (program time advances one period per cycle) -> kHolding (program finished:
// the final pose is held by the same control law) . A program always starts from the
// robot's actual pose (trajectory::rebase in start()), so enabling never moves the robot.
//
// The reference comes from one of two sources: the program sequencer (start()) or the
// streaming reference (start_streaming()), which follows setpoints handed to
// stream_setpoint() each cycle. While a stream runs, the safety filter's command-stream
// watchdog is on (SafetyInput::streaming) and fed by every accepted setpoint (stream_fresh);
// end_stream() is the normal end: the reference comes to rest and is held (kHolding), the
// watchdog is off, nothing is latched.
//
// start() and start_streaming() are set-up (may allocate and throw); step(), stream_setpoint()
// and end_stream() are noexcept and allocation-free.
#include <cstdint>
#include <optional>

#include "control/controller/controller.hpp"
#include "control/estimator/state_estimator.hpp"
#include "control/trajectory/limits.hpp"
#include "control/trajectory/program.hpp"
#include "control/trajectory/sequencer.hpp"
#include "control/trajectory/streaming_reference.hpp"
#include "drivers/actuator_set.hpp"
#include "safety/safety_filter.hpp"

namespace dualv::control {

// kStopped: the safety filter stopped the program (SS1/STO, then disabled after a reset);
// only start() leaves it.
enum class CyclePhase : std::uint8_t { kEnabling = 0, kRunning, kHolding, kStopped };
const char* to_string(CyclePhase p) noexcept;

enum class CycleStatus : std::uint8_t {
  kOk = 0,
  kIoError,         // the actuator set reported a bus error or stale data
  kEstimateFailed,  // forward kinematics failed: zero torque sent
  kControlFailed,   // reference or control law failed: zero torque sent
  kEnableTimeout,   // the drives did not reach Operation Enabled in time
  kSafetyStop,      // the safety filter is stopping or has stopped (record.safety says why)
};
const char* to_string(CycleStatus s) noexcept;

// One cycle's telemetry, plain fixed-size data (copied into the telemetry queue).
struct CycleRecord {
  std::int64_t cycle = 0;
  double t = 0.0;  // program time [s]
  CyclePhase phase = CyclePhase::kEnabling;
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

  // Set-up: reads the drives once, finds the plate pose by forward kinematics from home,
  // rebases `program` onto it, prepares the sequencer and arms the safety filter. Throws
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
  // A stream was started and has not ended (end_stream) or stopped (safety).
  bool streaming() const noexcept {
    return stream_ && stream_->active() && phase_ != CyclePhase::kStopped;
  }
  const trajectory::StreamingReference* stream() const noexcept {
    return stream_ ? &*stream_ : nullptr;
  }

  CycleStatus step(drivers::ActuatorSet& io, CycleRecord& record) noexcept;

  CyclePhase phase() const noexcept { return phase_; }
  bool program_finished() const noexcept { return phase_ == CyclePhase::kHolding; }
  double program_duration() const noexcept;
  const trajectory::Sequencer* sequencer() const noexcept {
    return sequencer_ ? &*sequencer_ : nullptr;
  }
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
  // Set-up: arms the safety filter and resets the cycle state (last step of a start).
  void arm(const drivers::ActuatorFeedback& fb, const model::JointVector& q, const model::Pose& X);
  bool has_reference() const noexcept { return sequencer_.has_value() || stream_.has_value(); }

  const model::Model* model_;
  CycleConfig config_;
  StateEstimator estimator_;
  Controller controller_;
  std::optional<trajectory::Sequencer> sequencer_;        // reference: a program, or
  std::optional<trajectory::StreamingReference> stream_;  // streamed setpoints
  CyclePhase phase_ = CyclePhase::kEnabling;
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
