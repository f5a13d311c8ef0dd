#pragma once
// Pre-flight: before anything moves, the whole program is sampled densely (every
// limits.sample_period and at least kMinIntervalsPerSegment times per segment, so a segment
// shorter than the step is still seen inside, plus each segment's two ends evaluated inside
// that segment) and checked
// against the model and the configured limits: workspace box, distance to parallel and serial
// singularities, joint speed, plate (angular) acceleration and peak joint torque from the
// inverse dynamics (eq. 1-3). With limits.loop_period set, the program is also sampled at the
// loop rate, as the controller will see it, and the joint speed between two consecutive cycles
// is checked (a move shorter than a cycle is a step there). Set-up code: allocates, may throw
// PreflightError.
//
// It can also choose the smallest blend time tau (eq. 16) or the shortest duration T of a
// shape segment that meets the limits, by bisection.
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "control/model/model.hpp"
#include "control/trajectory/limits.hpp"
#include "control/trajectory/program.hpp"

namespace dualv::trajectory {

inline constexpr int kMinIntervalsPerSegment = 16;

enum class LimitKind : std::uint8_t {
  kKinematics,  // the model refused the pose (unreachable, singular): value/bound unused
  kWorkspaceX,
  kWorkspaceY,
  kWorkspaceTheta,
  kParallelSingularity,
  kSerialSingularity,
  kJointSpeed,
  kPlateAcceleration,
  kPlateAngularAcceleration,
  kJointTorque,
  kDuration,  // a segment whose duration cannot be sampled (not finite, or too many samples)
};
const char* to_string(LimitKind k) noexcept;
// Configuration key of the limit, e.g. "trajectory.limits.max_joint_speed".
const char* limit_key(LimitKind k) noexcept;

struct Violation {
  LimitKind limit = LimitKind::kKinematics;
  std::size_t segment = 0;  // index into Program::segments()
  double t = 0.0;           // program time [s]
  double t_segment = 0.0;   // time into the segment [s]
  double value = 0.0;       // measured
  double bound = 0.0;       // configured limit
  int joint = -1;           // chain index for per-joint limits
  std::string message;      // names the segment, the time and the limit (value vs limit)
};

struct PreflightReport {
  std::vector<Violation> violations;  // the first of each limit kind in each segment
  // Extremes over the program, for logs and for sizing limits.
  double max_joint_speed = 0.0;
  double max_plate_acceleration = 0.0;
  double max_plate_angular_acceleration = 0.0;
  double max_joint_torque = 0.0;
  double min_parallel_singularity = 1e300;
  double min_serial_singularity = 1e300;
  std::size_t samples = 0;

  bool ok() const noexcept { return violations.empty(); }
  std::string summary() const;  // every violation's message, one per line
};

class PreflightError : public std::runtime_error {
 public:
  explicit PreflightError(PreflightReport report);
  const PreflightReport& report() const noexcept { return report_; }

 private:
  PreflightReport report_;
};

// Checks every segment.
PreflightReport preflight(const model::Model& model, const Program& program, const Limits& limits);
// Checks one segment.
PreflightReport preflight_segment(const model::Model& model, const Program& program,
                                  std::size_t segment, const Limits& limits);
// Throws PreflightError when preflight() finds a violation.
void preflight_or_throw(const model::Model& model, const Program& program, const Limits& limits);

// Smallest blend tau in (0, T/2) for shape segment `segment` that passes its pre-flight: the
// limits are not monotone in tau (a longer blend lowers the blend acceleration but raises the
// cruise speed (lambda_f - lambda0) / (T - tau), eq. 16), so a 48-point grid finds the first
// feasible tau and bisection refines it to `tolerance` [s]. Returns the program with that tau
// set; throws PreflightError (the least-violating grid report) when no tau passes, ConfigError
// when the segment is not a blended shape.
Program choose_blend_time(const model::Model& model, const Program& program, std::size_t segment,
                          const Limits& limits, double tolerance = 1e-4);
// choose_blend_time() for every shape loaded with `tau: auto` (Segment::auto_tau), clearing the
// flag. Segments on the original clock keep their flag untouched (no blend to choose).
Program resolve_auto_blends(const model::Model& model, const Program& program, const Limits& limits,
                            double tolerance = 1e-4);
// Shortest duration T in (0, max_duration] for shape segment `segment` (tau scaled with T, so
// tau / T is kept) that passes its pre-flight, grid then bisection to `tolerance` [s]. Later
// segments shift in time. Throws PreflightError when no T up to max_duration passes.
Program choose_duration(const model::Model& model, const Program& program, std::size_t segment,
                        const Limits& limits, double max_duration, double tolerance = 1e-4);

}  // namespace dualv::trajectory
