#pragma once
// One real-time control cycle, in the order DESIGN.md fixes:
//   drives -> read -> estimate -> reference -> control law -> (safety) -> write -> drives.
//
// Phases: kEnabling (zero torque, drives asked to enable; program clock stopped) ->
// kRunning (program time advances one period per cycle) -> kHolding (program finished:
// the final pose is held by the same control law) . A program always starts from the
// robot's actual pose (trajectory::rebase in start()), so enabling never moves the robot.
//
// start() is set-up (may allocate and throw); step() is noexcept and allocation-free.
#include <cstdint>
#include <optional>

#include "control/controller/controller.hpp"
#include "control/estimator/state_estimator.hpp"
#include "control/trajectory/limits.hpp"
#include "control/trajectory/program.hpp"
#include "control/trajectory/sequencer.hpp"
#include "drivers/actuator_set.hpp"

namespace dualv::control {

enum class CyclePhase : std::uint8_t { kEnabling = 0, kRunning, kHolding };
const char* to_string(CyclePhase p) noexcept;

enum class CycleStatus : std::uint8_t {
  kOk = 0,
  kIoError,         // the actuator set reported a bus error or stale data
  kEstimateFailed,  // forward kinematics failed: zero torque sent
  kControlFailed,   // reference or control law failed: zero torque sent
  kEnableTimeout,   // the drives did not reach Operation Enabled in time
};
const char* to_string(CycleStatus s) noexcept;

// One cycle's telemetry, plain fixed-size data (copied into the telemetry queue).
struct CycleRecord {
  std::int64_t cycle = 0;
  double t = 0.0;  // program time [s]
  CyclePhase phase = CyclePhase::kEnabling;
  CycleStatus status = CycleStatus::kOk;
  trajectory::Reference ref;  // X_d, q_d, lambda, segment ...
  StateEstimate est;          // q, q_dot, X, X_dot
  ControlOutput control;      // tau*, tau_pd, tau_ff, errors, internal part
  drivers::ActuatorCommand command;  // what was written to the drives
  drivers::ActuatorFeedback feedback;
};

struct CycleConfig {
  double period = 1e-3;          // [s]
  double enable_timeout = 2.0;   // [s] to reach Operation Enabled on every drive
};

class ControlCycle {
 public:
  ControlCycle(const model::Model& model, const ControlSetup& setup, const CycleConfig& config);

  // Set-up: reads the drives once, finds the plate pose by forward kinematics from home,
  // rebases `program` onto it and prepares the sequencer. Throws std::runtime_error with a
  // message when the drives cannot be read or the pose cannot be found.
  void start(drivers::ActuatorSet& io, const trajectory::Program& program,
             const trajectory::RebaseOptions& rebase);

  CycleStatus step(drivers::ActuatorSet& io, CycleRecord& record) noexcept;

  CyclePhase phase() const noexcept { return phase_; }
  bool program_finished() const noexcept { return phase_ == CyclePhase::kHolding; }
  double program_duration() const noexcept;
  const trajectory::Sequencer* sequencer() const noexcept {
    return sequencer_ ? &*sequencer_ : nullptr;
  }
  Controller& controller() noexcept { return controller_; }

 private:
  const model::Model* model_;
  CycleConfig config_;
  StateEstimator estimator_;
  Controller controller_;
  std::optional<trajectory::Sequencer> sequencer_;
  CyclePhase phase_ = CyclePhase::kEnabling;
  std::int64_t cycle_ = 0;
  std::int64_t enabling_cycles_ = 0;
  double t_ = 0.0;
  model::JointVector q_meas_;
};

}  // namespace dualv::control
