#pragma once
// The simulated Dual-V mechanism: exact rigid-body forward dynamics of all 2n + 1 bodies
// (control/model/dynamics.hpp) integrated with classic RK4 at a fixed internal step, plus
// the realism knobs of a real machine (issue 4), each switchable in the `plant:` section
// of the configuration:
//
//   command(tau)  --> [transport delay: the command of cycle k acts from cycle k+1]
//                 --> [torque quantisation: per mille of rated torque, CiA 402 6071h/6076h]
//                 --> [saturation at the drive's peak torque, N m]
//                 --> [current loop: first-order lag, time constant T]  = applied torque
//   applied torque - joint friction (Coulomb, smoothed near rest, + viscous) drives the "true"
//   model, whose masses and inertias differ from the configured (controller's) model by a
//   set percentage per body class (model mismatch).
//   Measured joint positions are the true ones rounded to the encoder's resolution.
//
// Cycle: command() once per controller cycle, then advance(period). advance() runs
// ceil(period / max_step) equal RK4 steps. Both are noexcept and allocate nothing after
// construction (all buffers live in model::Data with fixed storage). A failure (the plate
// leaves the reachable workspace, a singularity, a non-finite state) freezes the plant at
// its last good state and latches the status until reset(): the outputs are never NaN.
#include <yaml-cpp/yaml.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "control/model/lane_dynamics.hpp"
#include "control/model/model.hpp"

namespace dualv::sim {

// Longest transport delay the plant can model, in controller cycles.
inline constexpr int kMaxDelayCycles = 8;

// Mass and inertia change of one body class in the plant relative to the configured model
// [%]: +5 means the plant's bodies are 5 % heavier than the controller believes.
struct MismatchPercent {
  double mass = 0.0;
  double inertia = 0.0;
};

struct PlantConfig {
  // Fixed RK4 step upper bound [s]; advance(period) uses ceil(period / max_step) equal steps.
  double max_step = 1e-4;  // 10 kHz

  struct Friction {
    bool enabled = true;
    double coulomb = 0.2;   // [N m] bearing/seal friction of each direct-drive motor joint
    double viscous = 0.02;  // [N m s/rad]
    // The Coulomb term is coulomb * s(q_dot / v_s) with the smoothstep
    // s(z) = z (15 - 10 z^2 + 3 z^4) / 8 for |z| < 1 and sign(z) beyond: full Coulomb
    // friction from v_s on, twice continuously differentiable everywhere. A true sign()
    // would make the right-hand side discontinuous and RK4 lose its order at every velocity
    // reversal; the steepest slope 15/8 coulomb / v_s [N m s/rad] (at rest) must stay well
    // inside RK4's stability region (step * slope / inertia << 2.8; here
    // 1e-4 * 37.5 / 0.04 = 0.09). A polynomial, not tanh: no exp on the RK4's hot path.
    double smoothing_velocity = 0.01;  // v_s [rad/s]
  } friction;

  struct Mismatch {
    bool enabled = true;
    MismatchPercent crank{5.0, 5.0};
    MismatchPercent coupler{5.0, 5.0};
    MismatchPercent plate{10.0, 10.0};  // the plate also carries an unmodelled tool
  } mismatch;

  struct Encoder {
    bool enabled = true;
    // Counts per joint revolution (608Fh). 2^20: a sin/cos or digital encoder on a
    // direct-drive torque motor interpolated to 20 bits (about 6 urad, 1.7 um at the
    // 0.28 m crank tip).
    std::int64_t counts_per_revolution = 1 << 20;
  } encoder;

  struct TorqueQuantisation {
    bool enabled = true;
    // Motor rated torque 6076h [N m]; target torque 6071h is an integer per mille of it,
    // so the command resolution is rated / 1000 (0.05 N m here). 50 N m is an
    // assumption of the order of the continuous torque of a 127 N m peak torque motor.
    double rated_torque = 50.0;
  } torque_quantisation;

  struct CurrentLoop {
    bool enabled = true;
    double time_constant = 2e-4;  // [s] closed current (torque) loop, ~800 Hz bandwidth
  } current_loop;

  struct Saturation {
    bool enabled = true;
    double peak_torque = 127.0;  // [N m] the ETEL drives' peak (docs/architecture.md)
  } saturation;

  struct TransportDelay {
    bool enabled = true;
    int cycles = 1;  // a command given at cycle k is applied from cycle k + cycles
  } transport_delay;

  // Not a YAML key: the plant's bodies given outright (e.g. the robot a model was identified on,
  // so that a controller with the identified model meets the same machine: `dualv identify`).
  // When set, `mismatch` is not applied; the geometry must be the configured model's.
  std::optional<model::Model> true_model;

  // Not a YAML key: false keeps the dynamics on the baseline x86-64 (SSE2) code path even on
  // a CPU with AVX2 (model::LaneDynamics), so benchmarks can show what a target PC without
  // AVX2 gets.
  bool allow_avx2 = true;

  // Every knob off: the ideal plant (exact configured model, torque applied at once).
  static PlantConfig ideal() noexcept;
};

// Reads the `plant:` map (see config/dualv.yaml). Missing keys take the defaults above;
// unknown keys and out-of-range values throw dualv::ConfigError naming every key.
PlantConfig load_plant_config(const YAML::Node& plant_node);
PlantConfig load_plant_config_file(const std::string& path);

// The plant's "true" model: config.true_model when set, else the configured one with the
// mismatch percentages applied.
model::Model make_true_model(const model::Model& configured, const PlantConfig& config) noexcept;

enum class PlantStatus : std::uint8_t {
  kOk = 0,
  kUnreachable,     // latched: the plate left the reachable workspace or met a singularity
  kInvalidCommand,  // this cycle's command had a non-finite entry or the wrong size: 0 N m used
  kInvalidPeriod,   // advance() called with a non-finite or non-positive duration: no step
};

const char* to_string(PlantStatus s) noexcept;

// Everything the plant reports after each advance() (and after reset()).
struct PlantOutput {
  double time = 0.0;                          // [s] robot time since reset
  std::uint64_t cycle = 0;                    // advance() calls since reset
  model::Pose X = model::Pose::Zero();        // true plate pose
  model::Twist X_dot = model::Twist::Zero();  // true plate twist
  model::JointVector q;                       // true joint angles [rad], continuous (unwrapped)
  model::JointVector q_dot;                   // [rad/s]
  model::JointVector q_measured;              // encoder-quantised q [rad] = counts * 2 pi / cpr
  std::array<std::int64_t, model::kMaxChains> counts{};  // encoder counts (q / resolution)
  model::JointVector tau_command;                        // last command as given [N m]
  model::JointVector tau_target;    // current-loop input: delayed, quantised, saturated [N m]
  model::JointVector tau_applied;   // motor torque actually produced now [N m]
  model::JointVector tau_friction;  // joint friction torque now (opposes motion) [N m]
  // Component of tau_applied in the null space of Jm^T: N tau (internal, antagonistic
  // torque that produces no motion), and its Euclidean norm [N m].
  model::JointVector tau_internal;
  double internal_norm = 0.0;
  // Why the plant latched kUnreachable (model::Status::kOk while it has not).
  model::Status fault = model::Status::kOk;
};

class Plant {
 public:
  // `configured` is the controller's model; the plant integrates make_true_model() of it.
  // Starts at rest at configured.home. Set-up: may allocate, does not throw.
  Plant(const model::Model& configured, const PlantConfig& config);

  // Back to rest (or the given twist) at pose X; clears torques, delay line, latched status.
  // kUnreachable if X is not a valid pose (the plant keeps its previous state then).
  PlantStatus reset(const model::Pose& X,
                    const model::Twist& X_dot = model::Twist::Zero()) noexcept;

  // This cycle's torque command [N m], one per joint (size n). Non-finite entries or a
  // wrong size: the whole command becomes 0 N m and kInvalidCommand is returned.
  PlantStatus command(const model::JointVector& tau) noexcept;

  // Integrates `period` seconds of robot time (one controller cycle). Returns kOk, or the
  // latched kUnreachable (the state stays frozen at the last good step), or kInvalidPeriod.
  PlantStatus advance(double period) noexcept;

  PlantStatus status() const noexcept { return latched_; }
  const PlantOutput& output() const noexcept { return out_; }
  const model::Model& true_model() const noexcept { return true_model_; }
  const PlantConfig& config() const noexcept { return config_; }
  int size() const noexcept { return true_model_.n; }

  // Energies of the true model at the current state [J] (tests, diagnostics). noexcept.
  double kinetic_energy() noexcept;
  double potential_energy() noexcept;
  double energy() noexcept { return kinetic_energy() + potential_energy(); }

  // Plate acceleration for the state and motor torques given (friction included when on),
  // the right-hand side the integrator uses [m/s^2, rad/s^2]. For tests.
  model::Status acceleration(const model::Pose& X, const model::Twist& X_dot,
                             const model::JointVector& tau_motor, model::Twist& X_dd) noexcept;

 private:
  struct State {
    model::Pose X;
    model::Twist X_dot;
  };
  // Drive-side processing of a command: quantisation and saturation [N m].
  double drive_target(double tau) const noexcept;
  // Joint friction torque (opposes motion) for a joint velocity [N m], and for all joints.
  double joint_friction(double q_dot) const noexcept;
  void friction(const model::JointVector& q_dot, model::JointVector& f) const noexcept;
  // dy/dt at y, with the motor torque exp(-s / T) = `decay` of the way into the step.
  model::Status derivative(const State& y, double decay, State& dy) noexcept;
  void refresh_output() noexcept;

  model::Model true_model_;
  PlantConfig config_;
  model::Data data_;
  // The right-hand side with the chains in SIMD lanes when the model allows it (couplers'
  // centres of mass on their axes), else update_dynamics.
  std::optional<model::LaneDynamics> lanes_;
  model::LaneDynamics::Output lane_out_;
  State y_{};
  PlantStatus latched_ = PlantStatus::kOk;
  // Delay line of drive targets (ring of D + 1 slots, D = delay cycles; head_ = next write).
  std::array<model::JointVector, kMaxDelayCycles + 1> delay_line_{};
  int head_ = 0;
  model::JointVector pending_;   // last command after the drive's quantisation/saturation
  model::JointVector target_;    // current-loop input during this cycle [N m]
  model::JointVector tau0_;      // motor torque at the start of the current RK4 step [N m]
  model::JointVector motor_;     // scratch: motor torque at a stage [N m]
  model::JointVector friction_;  // scratch: friction at a stage [N m]
  // 1 / friction.smoothing_velocity: a multiplication per joint and stage, not a division
  // (divisions bound this loop's speed).
  double inv_smoothing_velocity_ = 0.0;
  PlantOutput out_;
};

}  // namespace dualv::sim
