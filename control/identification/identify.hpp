#pragma once
// Dynamic parameter identification from a recorded run (issue 16), set-up code:
//
//   logged plate poses X_k (forward kinematics of the encoders) and torques sent tau_k
//   -> zero-phase low-pass of X and tau (zero_phase_filter.hpp), X_dot and X_dd by central
//      differences of the filtered X
//   -> the torques shifted by the drive chain's latency (transport delay, zero-order hold,
//      current loop), so that torque and motion belong to the same instant
//   -> decimation (the filtered rows are not independent), samples with a joint near rest
//      dropped (the sign of its Coulomb friction is unknown there)
//   -> y_k = Jm^T tau_k = W_1 phi_b (the actuated projection: internal torques are invisible)
//   -> weighted least squares (estimation.hpp) with the reference motion's regressor as
//      instruments when the recording has the reference (the closed loop's torques react to
//      the encoder noise that W carries: plain least squares is biased), and a covariance that
//      accounts for the filtered residuals' correlation
//
// A recording too short or not exciting enough is refused (IdentificationError) with what to
// change.
#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>

#include "control/identification/base_parameters.hpp"
#include "control/identification/estimation.hpp"
#include "control/model/model.hpp"

namespace dualv::identification {

// A logged run: one entry per control cycle, equally spaced by `period`.
struct Recording {
  double period = 0.001;                // [s]
  std::vector<double> t;                // [s]
  std::vector<model::Pose> X;           // measured plate pose
  std::vector<model::JointVector> tau;  // torque sent to the motors [N m]
  // The reference pose the controller followed (X_d of the logs); empty when unknown.
  std::vector<model::Pose> X_ref;
  std::size_t size() const noexcept { return t.size(); }
};

struct IdentifyOptions {
  int filter_order = 4;
  double cutoff_hz = 50.0;        // low-pass of poses and torques
  int decimation = 4;             // keep every k-th filtered sample (Nyquist 125 Hz at 1 kHz)
  double torque_delay = 0.0;      // [s] the torque sent at t acts at t + torque_delay
  double min_joint_speed = 0.05;  // [rad/s] samples with a slower joint are dropped
  double trim = 0.05;             // [s] dropped at each end (filter edges)
  double min_duration = 1.0;      // [s] of usable samples, at least
  double max_condition = 500.0;   // refuse a scaled condition number above this
  // Instrumental variables from the reference motion (when the recording has it).
  bool instruments = true;
  // Residuals closer in time than correlation_periods / cutoff_hz are treated as correlated in
  // the covariance (Newey-West, estimation.hpp); 0: white residuals (optimistic sigma).
  double correlation_periods = 3.0;
};

class IdentificationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The samples of a recording, processed as above (before decimation and selection).
struct ProcessedRecording {
  std::vector<double> t;
  std::vector<model::Pose> X;
  std::vector<model::Twist> X_dot, X_dd;
  std::vector<model::JointVector> tau;  // filtered and shifted by the latency
  // The reference motion, filtered and differentiated alike (empty when not recorded).
  std::vector<model::Pose> X_ref;
  std::vector<model::Twist> X_ref_dot, X_ref_dd;
};
ProcessedRecording process(const Recording& rec, const IdentifyOptions& options);

// Stacked observations of the base parameters' regressor from the processed samples
// (decimated, selected as above).
Observations observations(const model::Model& model, const BaseParameters& base,
                          const ProcessedRecording& p, const IdentifyOptions& options);

struct Identification {
  BaseParameters base;
  Estimate estimate;
  Eigen::VectorXd nominal;        // base parameters of the nominal model and friction
  double duration = 0.0;          // [s] of samples used
  double correlation_time = 0.0;  // [s] of the Newey-West sigma (0: white residuals)
};

// Throws IdentificationError (too short, too few moving samples, condition number too high:
// each message says what to change).
Identification identify(const model::Model& model, const Eigen::VectorXd& nominal_standard,
                        const Recording& rec, const IdentifyOptions& options);

// Measured vs predicted joint torques along a recording: measured R tau (its part in
// range(Jm), the only part that moves the plate), predicted Jm^{T*} W_1 phi_b (minimum norm).
struct TorqueComparison {
  std::vector<double> t;
  std::vector<model::JointVector> measured, predicted;
  double rms_error = 0.0, rms_measured = 0.0;  // [N m] over all joints
};
TorqueComparison compare_torques(const model::Model& model, const BaseParameters& base,
                                 const Eigen::VectorXd& phi_b, const Recording& rec,
                                 const IdentifyOptions& options);

}  // namespace dualv::identification
