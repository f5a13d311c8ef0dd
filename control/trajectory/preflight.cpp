#include "control/trajectory/preflight.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "common/config_error.hpp"
#include "control/model/dynamics.hpp"
#include "control/model/kinematics.hpp"
#include "control/trajectory/sample_count.hpp"

namespace dualv::trajectory {

const char* to_string(LimitKind k) noexcept {
  switch (k) {
    case LimitKind::kKinematics:
      return "kinematics";
    case LimitKind::kWorkspaceX:
      return "workspace x";
    case LimitKind::kWorkspaceY:
      return "workspace y";
    case LimitKind::kWorkspaceTheta:
      return "workspace theta";
    case LimitKind::kParallelSingularity:
      return "parallel singularity distance";
    case LimitKind::kSerialSingularity:
      return "serial singularity distance";
    case LimitKind::kJointSpeed:
      return "joint speed";
    case LimitKind::kPlateAcceleration:
      return "plate acceleration";
    case LimitKind::kPlateAngularAcceleration:
      return "plate angular acceleration";
    case LimitKind::kJointTorque:
      return "joint torque";
    case LimitKind::kDuration:
      return "segment duration";
  }
  return "?";
}

const char* limit_key(LimitKind k) noexcept {
  switch (k) {
    case LimitKind::kKinematics:
      return "model";
    case LimitKind::kWorkspaceX:
      return "trajectory.limits.workspace.x";
    case LimitKind::kWorkspaceY:
      return "trajectory.limits.workspace.y";
    case LimitKind::kWorkspaceTheta:
      return "trajectory.limits.workspace.theta";
    case LimitKind::kParallelSingularity:
      return "trajectory.limits.min_parallel_singularity";
    case LimitKind::kSerialSingularity:
      return "trajectory.limits.min_serial_singularity";
    case LimitKind::kJointSpeed:
      return "trajectory.limits.max_joint_speed";
    case LimitKind::kPlateAcceleration:
      return "trajectory.limits.max_plate_acceleration";
    case LimitKind::kPlateAngularAcceleration:
      return "trajectory.limits.max_plate_angular_acceleration";
    case LimitKind::kJointTorque:
      return "trajectory.limits.max_joint_torque";
    case LimitKind::kDuration:
      return "trajectory.limits.sample_period";
  }
  return "?";
}

std::string PreflightReport::summary() const {
  std::string out;
  for (const auto& v : violations) {
    if (!out.empty()) out += '\n';
    out += v.message;
  }
  return out;
}

PreflightError::PreflightError(PreflightReport report)
    : std::runtime_error("pre-flight refused the program:\n" + report.summary()),
      report_(std::move(report)) {}

namespace {

constexpr int kMaxIntervalsPerSegment = 100'000'000;

class Checker {
 public:
  Checker(const model::Model& model, const Limits& limits, PreflightReport& report)
      : model_(model), data_(model), limits_(limits), report_(report) {}

  // The program as the loop samples it, one pose per cycle: the joint speed between two
  // consecutive cycles, |q_k - q_k-1| / loop_period. By the mean value theorem it never
  // exceeds the analytic peak of a continuous motion, so it adds no false refusal; it catches
  // what a cycle sees as a step (a move shorter than the period).
  void check_loop_rate(const Program& program) {
    const double dt = limits_.loop_period;
    const auto cycles = sample_intervals(program.duration(), dt, 1, kMaxIntervalsPerSegment);
    if (!cycles) return;  // check_segment() has refused the durations
    std::vector<std::uint32_t> seen(program.size(), 0);
    CartesianSample c;
    PhaseSample ph;
    model::JointVector q, q_prev;
    for (int i = 0; i <= *cycles; ++i) {
      const double t = dt * i;
      const std::size_t k = program.sample(t, c, ph);
      if (model::inverse_kinematics(model_, data_, c.X, q) != model::Status::kOk) {
        q_prev.resize(0);  // check_segment() names the pose; restart the differences
        continue;
      }
      if (q_prev.size() == q.size() && k < program.size()) {
        int j = 0;
        const double speed = (q - q_prev).cwiseAbs().maxCoeff(&j) / dt;
        if (speed > limits_.max_joint_speed * (1.0 + 1e-9)) {
          const Segment& s = program.segments()[k];
          add({s, k, t, t - s.t_start}, seen[k], LimitKind::kJointSpeed, speed,
              limits_.max_joint_speed, j,
              fmt::format("at the loop rate ({:.6g} s per cycle) joint {} moves {:.4g} rad in one "
                          "cycle: {:.4g} rad/s exceeds the limit {:.4g} rad/s",
                          dt, j + 1, speed * dt, speed, limits_.max_joint_speed));
        }
      }
      q_prev = q;
    }
  }

  void check_segment(const Program& program, std::size_t k) {
    const Segment& s = program.segments()[k];
    const double T = s.duration();
    const double period = limits_.sample_period > 0.0 ? limits_.sample_period : 5e-4;
    std::uint32_t seen = 0;
    const auto intervals =
        sample_intervals(T, period, kMinIntervalsPerSegment, kMaxIntervalsPerSegment);
    if (!intervals) {
      add({s, k, s.t_start, 0.0}, seen, LimitKind::kDuration, T, period, -1,
          fmt::format("duration {} s cannot be sampled every {} s (at most {} samples)", T, period,
                      kMaxIntervalsPerSegment));
      return;
    }
    const int n = *intervals;
    CartesianSample c;
    PhaseSample ph;
    for (int i = 0; i <= n; ++i) {
      const double tl = T * i / n;  // both ends evaluated inside this segment
      s.sample(tl, c, ph);
      check_sample(s, k, s.t_start + tl, tl, c, seen);
    }
  }

 private:
  struct Where {
    const Segment& s;
    std::size_t k;
    double t, tl;
  };

  void add(const Where& w, std::uint32_t& seen, LimitKind kind, double value, double bound,
           int joint, const std::string& what) {
    const auto bit = 1u << static_cast<unsigned>(kind);
    if (seen & bit) return;
    seen |= bit;
    Violation v;
    v.limit = kind;
    v.segment = w.k;
    v.t = w.t;
    v.t_segment = w.tl;
    v.value = value;
    v.bound = bound;
    v.joint = joint;
    v.message = fmt::format("{} at t = {:.6f} s (segment t = {:.6f} s): {} ({})", w.s.label, w.t,
                            w.tl, what, limit_key(kind));
    report_.violations.push_back(std::move(v));
  }

  void check_sample(const Segment& s, std::size_t k, double t, double tl, const CartesianSample& c,
                    std::uint32_t& seen) {
    const Where w{s, k, t, tl};
    ++report_.samples;
    const Workspace& ws = limits_.workspace;
    const Interval* box[3] = {&ws.x, &ws.y, &ws.theta};
    const LimitKind kinds[3] = {LimitKind::kWorkspaceX, LimitKind::kWorkspaceY,
                                LimitKind::kWorkspaceTheta};
    const char* names[3] = {"x", "y", "theta"};
    const char* units[3] = {"m", "m", "rad"};
    for (int i = 0; i < 3; ++i) {
      if (!box[i]->contains(c.X[i])) {
        const double bound = c.X[i] < box[i]->lo ? box[i]->lo : box[i]->hi;
        add(w, seen, kinds[i], c.X[i], bound, -1,
            fmt::format("{} = {:.6g} {} outside the workspace [{}, {}]", names[i], c.X[i], units[i],
                        box[i]->lo, box[i]->hi));
      }
    }

    const model::Status st = model::update_kinematics(model_, data_, c.X, c.X_dot);
    if (st != model::Status::kOk) {
      add(w, seen, LimitKind::kKinematics, 0.0, 0.0, -1,
          fmt::format("the model refuses the pose ({:.6g}, {:.6g}, {:.6g}): {}", c.X[0], c.X[1],
                      c.X[2], model::to_string(st)));
      return;
    }
    const model::SingularityMeasures sm = model::singularity_measures(model_, data_);
    report_.min_parallel_singularity = std::min(report_.min_parallel_singularity, sm.parallel);
    report_.min_serial_singularity = std::min(report_.min_serial_singularity, sm.min_serial);
    if (sm.parallel < limits_.min_parallel_singularity)
      add(w, seen, LimitKind::kParallelSingularity, sm.parallel, limits_.min_parallel_singularity,
          -1,
          fmt::format("parallel singularity measure {:.4g} below the limit {:.4g}", sm.parallel,
                      limits_.min_parallel_singularity));
    if (sm.min_serial < limits_.min_serial_singularity) {
      int j = 0;
      for (int i = 1; i < model_.n; ++i)
        if (sm.serial[i] < sm.serial[j]) j = i;
      add(w, seen, LimitKind::kSerialSingularity, sm.min_serial, limits_.min_serial_singularity, j,
          fmt::format("serial singularity measure {:.4g} of chain {} below the limit {:.4g}",
                      sm.min_serial, j + 1, limits_.min_serial_singularity));
    }

    int j = 0;
    const double qd = data_.q_dot.cwiseAbs().maxCoeff(&j);
    report_.max_joint_speed = std::max(report_.max_joint_speed, qd);
    if (qd > limits_.max_joint_speed)
      add(w, seen, LimitKind::kJointSpeed, qd, limits_.max_joint_speed, j,
          fmt::format("joint {} speed {:.4g} rad/s exceeds the limit {:.4g} rad/s", j + 1, qd,
                      limits_.max_joint_speed));

    const double acc = c.X_dd.head<2>().norm();
    report_.max_plate_acceleration = std::max(report_.max_plate_acceleration, acc);
    if (acc > limits_.max_plate_acceleration)
      add(w, seen, LimitKind::kPlateAcceleration, acc, limits_.max_plate_acceleration, -1,
          fmt::format("plate acceleration {:.4g} m/s^2 exceeds the limit {:.4g} m/s^2", acc,
                      limits_.max_plate_acceleration));
    const double aacc = std::abs(c.X_dd[2]);
    report_.max_plate_angular_acceleration = std::max(report_.max_plate_angular_acceleration, aacc);
    if (aacc > limits_.max_plate_angular_acceleration)
      add(w, seen, LimitKind::kPlateAngularAcceleration, aacc,
          limits_.max_plate_angular_acceleration, -1,
          fmt::format("plate angular acceleration {:.4g} rad/s^2 exceeds the limit {:.4g} rad/s^2",
                      aacc, limits_.max_plate_angular_acceleration));

    // Peak torque from the inverse dynamics on the desired motion (eq. 1-3, tau = Jm^{T*} F_X).
    const model::Status dst = model::inverse_dynamics(model_, data_, c.X, c.X_dot, c.X_dd, tau_);
    if (dst != model::Status::kOk) {
      add(w, seen, LimitKind::kKinematics, 0.0, 0.0, -1,
          fmt::format("the inverse dynamics refuse the pose ({:.6g}, {:.6g}, {:.6g}): {}", c.X[0],
                      c.X[1], c.X[2], model::to_string(dst)));
      return;
    }
    const double tq = tau_.cwiseAbs().maxCoeff(&j);
    report_.max_joint_torque = std::max(report_.max_joint_torque, tq);
    if (tq > limits_.max_joint_torque)
      add(w, seen, LimitKind::kJointTorque, tq, limits_.max_joint_torque, j,
          fmt::format("joint {} torque {:.4g} N m exceeds the limit {:.4g} N m", j + 1, tq,
                      limits_.max_joint_torque));
  }

  const model::Model& model_;
  model::Data data_;
  const Limits& limits_;
  PreflightReport& report_;
  model::JointVector tau_;
};

const Segment& blended_shape(const Program& program, std::size_t segment, bool need_blend) {
  if (segment >= program.size())
    throw ConfigError(
        {fmt::format("segment {}: no such segment (program has {})", segment, program.size())});
  const Segment& s = program.segments()[segment];
  if (s.kind != SegmentKind::kShape)
    throw ConfigError({fmt::format("{}: not a shape segment", s.label)});
  if (need_blend && s.motion.timing.kind == TimingKind::kOriginal)
    throw ConfigError({fmt::format("{}: the original clock (eq. 9) has no blend time", s.label)});
  return s;
}

// Smallest x in (lo, hi] with feasible(x): the limits are not monotone in the parameter (a
// longer blend lowers the blend acceleration but raises the cruise speed, eq. 16), so a grid
// finds the first feasible point and bisection refines between it and its infeasible
// neighbour. Throws PreflightError with the report at the best grid point when none is
// feasible. Leaves the caller's state at the returned x (feasible() is called on it last).
template <class F>
double smallest_feasible(double lo, double hi, double tolerance, F&& feasible) {
  constexpr int kGrid = 48;
  PreflightReport best;
  bool have_best = false;
  for (int i = 1; i <= kGrid; ++i) {
    const double x = lo + (hi - lo) * i / kGrid;
    PreflightReport r;
    if (feasible(x, &r)) {
      double a = lo + (hi - lo) * (i - 1) / kGrid;  // infeasible (or the open bound lo)
      double b = x;
      while (b - a > tolerance) {
        const double mid = 0.5 * (a + b);
        if (mid <= lo) break;
        (feasible(mid, nullptr) ? b : a) = mid;
      }
      feasible(b, nullptr);
      return b;
    }
    if (!have_best || r.violations.size() < best.violations.size()) {
      best = std::move(r);
      have_best = true;
    }
  }
  throw PreflightError(std::move(best));
}

}  // namespace

PreflightReport preflight(const model::Model& model, const Program& program, const Limits& limits) {
  PreflightReport report;
  Checker checker(model, limits, report);
  for (std::size_t k = 0; k < program.size(); ++k) checker.check_segment(program, k);
  if (limits.loop_period > 0.0) checker.check_loop_rate(program);
  return report;
}

PreflightReport preflight_segment(const model::Model& model, const Program& program,
                                  std::size_t segment, const Limits& limits) {
  PreflightReport report;
  Checker checker(model, limits, report);
  if (segment < program.size()) checker.check_segment(program, segment);
  return report;
}

void preflight_or_throw(const model::Model& model, const Program& program, const Limits& limits) {
  PreflightReport report = preflight(model, program, limits);
  if (!report.ok()) throw PreflightError(std::move(report));
}

Program choose_blend_time(const model::Model& model, const Program& program, std::size_t segment,
                          const Limits& limits, double tolerance) {
  const Segment& s = blended_shape(program, segment, true);
  Program work = program;
  TimingLaw law = s.motion.timing;
  auto feasible = [&](double tau, PreflightReport* out) {
    law.tau = tau;
    work.set_timing(segment, law);
    PreflightReport r = preflight_segment(model, work, segment, limits);
    const bool ok = r.ok();
    if (out) *out = std::move(r);
    return ok;
  };
  const double hi = 0.5 * law.T * (1.0 - 1e-9);
  const double x = smallest_feasible(0.0, hi, tolerance, feasible);
  law.tau = x;
  work.set_timing(segment, law);
  return work;
}

Program resolve_auto_blends(const model::Model& model, const Program& program, const Limits& limits,
                            double tolerance) {
  Program out = program;
  for (std::size_t k = 0; k < out.size(); ++k) {
    const Segment& s = out.segments()[k];
    if (s.kind != SegmentKind::kShape || !s.auto_tau ||
        s.motion.timing.kind == TimingKind::kOriginal)
      continue;
    out = choose_blend_time(model, out, k, limits, tolerance);
    out.mutable_segments()[k].auto_tau = false;
  }
  return out;
}

Program choose_duration(const model::Model& model, const Program& program, std::size_t segment,
                        const Limits& limits, double max_duration, double tolerance) {
  const Segment& s = blended_shape(program, segment, false);
  if (!(max_duration > 0.0))
    throw ConfigError({fmt::format("max_duration: must be > 0 (got {})", max_duration)});
  Program work = program;
  TimingLaw law = s.motion.timing;
  const double ratio = law.tau / law.T;
  auto feasible = [&](double T, PreflightReport* out) {
    law.T = T;
    law.tau = ratio * T;
    work.set_timing(segment, law);
    PreflightReport r = preflight_segment(model, work, segment, limits);
    const bool ok = r.ok();
    if (out) *out = std::move(r);
    return ok;
  };
  smallest_feasible(0.0, max_duration, tolerance, feasible);  // leaves `work` at the result
  return work;
}

}  // namespace dualv::trajectory
