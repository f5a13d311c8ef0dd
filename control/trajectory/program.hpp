#pragma once
// A motion program: an ordered list of segments (PtP move, shape with its timing law, dwell),
// each starting where the previous one ends (Bennehar et al. 2014, section V: shapes joined by
// 5th-order PtP moves). Loading and editing are set-up code (throw dualv::ConfigError);
// sampling is noexcept and allocation-free.
//
// YAML (the `program:` map; config/paper.yaml is the paper's experiment):
//   program:
//     timing_override: original      # optional: force every shape's timing law (comparison runs)
//     segments:
//       - ptp: {to: [x, y, theta], duration: 0.4}   # to: a pose, `home`, or omitted = start of
//                                                   # the next segment (a shape); optional
//                                                   # from: must equal the previous end
//       - shape: {type: circle, T: 0.5, timing: retimed, tau: 0.1}
//         # type: circle | ellipse | tear | deltoid | custom; optional centre (default home),
//         # scale (built-ins), lambda0 (0), lambda_f (2 pi), timing (retimed | smooth |
//         # original), tau (0 < tau < T/2, required unless original; `auto`: the smallest
//         # tau meeting the limits, see resolve_auto_blends()); custom shapes give
//         # terms: {x: [{a, alpha, n1, b, beta, n2}, ...], y: [...], theta: [...]} (eq. 4)
//       - dwell: {duration: 0.2}
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "control/trajectory/limits.hpp"
#include "control/trajectory/ptp.hpp"
#include "control/trajectory/sample.hpp"
#include "control/trajectory/shape.hpp"
#include "control/trajectory/timing_law.hpp"

namespace dualv::trajectory {

// Bounds on what a program may ask for (issue 14): beyond them a value is a mistake, and
// within them every count derived from a program (samples, cycles, log rows) is small.
inline constexpr double kMaxSegmentDuration = 600.0;   // [s] a ptp, dwell or shape T
inline constexpr double kMaxProgramDuration = 3600.0;  // [s] the whole program
inline constexpr std::size_t kMaxSegments = 10000;

enum class SegmentKind : std::uint8_t { kPtp, kShape, kDwell };
const char* to_string(SegmentKind kind) noexcept;

struct ShapeMotion {
  Shape shape;
  TimingLaw timing;
};

struct Segment {
  SegmentKind kind = SegmentKind::kDwell;
  std::string label;                // e.g. "program.segments[3] (shape circle)": for messages only
  double t_start = 0.0;             // program time of the segment start [s] (set by Program)
  PtpMove ptp;                      // kind == kPtp
  ShapeMotion motion;               // kind == kShape
  Dwell dwell;                      // kind == kDwell
  bool start_from_previous = true;  // PtP: start pose not given (follows the previous end)
  bool auto_tau = false;  // shape: `tau: auto`, resolved by resolve_auto_blends() (preflight.hpp);
                          // until then tau = T/5

  double duration() const noexcept;
  Pose start_pose() const noexcept;
  Pose end_pose() const noexcept;
  // Sample at segment time t (from the segment start). phase is the shape's lambda (zero for
  // PtP and dwell). noexcept, no allocation.
  void sample(double t, CartesianSample& out, PhaseSample& phase) const noexcept;
};

class Program {
 public:
  Program() = default;
  explicit Program(const Pose& start) : start_(start) {}

  // Builders (set-up). Each segment starts at the previous end (or the program start).
  // Throw ConfigError on invalid durations (not in (0, kMaxSegmentDuration], or a program
  // longer than kMaxProgramDuration) / timing laws.
  Program& add_ptp(const Pose& to, double duration, std::string label = {});
  Program& add_shape(const Shape& shape, const TimingLaw& timing, std::string label = {});
  Program& add_dwell(double duration, std::string label = {});

  const std::vector<Segment>& segments() const noexcept { return segments_; }
  std::size_t size() const noexcept { return segments_.size(); }
  double duration() const noexcept { return duration_; }
  const Pose& start_pose() const noexcept { return start_; }
  Pose end_pose() const noexcept;

  // Index of the segment active at program time t: the last one with t_start <= t, clamped to
  // [0, size - 1]. noexcept, O(log n).
  std::size_t segment_at(double t) const noexcept;
  // Cartesian sample at program time t; returns the segment index (0 for an empty program,
  // which holds the start pose). Before 0 (and for NaN) and after duration() the robot is at
  // rest at the first / last pose. noexcept, no allocation.
  std::size_t sample(double t, CartesianSample& out, PhaseSample& phase) const noexcept;

  // Replaces a shape segment's timing law and re-times the program (set-up; validates).
  void set_timing(std::size_t segment, const TimingLaw& timing);

  // Mutable access for set-up code that edits segments in place; call retime() afterwards.
  std::vector<Segment>& mutable_segments() noexcept { return segments_; }
  void set_start_pose(const Pose& start) noexcept { start_ = start; }
  // Recomputes segment start times and chains every segment's start to the previous end.
  void retime() noexcept;

 private:
  Pose start_ = Pose::Zero();
  std::vector<Segment> segments_;
  double duration_ = 0.0;
};

struct ProgramContext {
  Pose start = Pose::Zero();  // where the first segment starts (the robot's pose, or home)
  Pose home = Pose::Zero();   // `to: home` and the default shape centre
  // When set, every segment's path is checked against the box at load time.
  std::optional<Workspace> workspace;
  double workspace_check_period = 5e-4;  // [s]
};

// Reads the `program:` map (key path "program"). Throws ConfigError listing every problem.
Program load_program(const YAML::Node& program_node, const ProgramContext& context);
// Reads `program:` from a file.
Program load_program_file(const std::string& path, const ProgramContext& context);

// A copy of `program` with every shape's timing law set to `kind` (same T, lambda0, lambda_f);
// a blended law without a valid tau gets tau = default_tau_fraction * T. Runs the same program
// on the original clock (eq. 9) and the retimed one (eq. 16) for comparison.
Program with_timing(const Program& program, TimingKind kind, double default_tau_fraction = 0.2);

// Starts `program` from the robot's actual pose so it never begins with a jump: when the first
// segment is a PtP without an explicit start, its start becomes `actual` and its duration is
// stretched to the rebase limits if needed; otherwise (and the first pose differs from
// `actual`) a PtP from `actual` within the rebase limits is put in front.
Program rebase(const Program& program, const Pose& actual, const RebaseOptions& options);

}  // namespace dualv::trajectory
