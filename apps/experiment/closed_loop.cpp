#include "apps/experiment/closed_loop.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>

#include "control/loop/control_cycle.hpp"
#include "sim/plant.hpp"
#include "sim/sim_actuator_set.hpp"

namespace dualv::apps {

std::vector<Variant> paper_variants() {
  using trajectory::TimingKind;
  return {
      {"retimed", TimingKind::kRetimed, true, true},
      {"original", TimingKind::kOriginal, true, true},
      {"retimed-no-projection", TimingKind::kRetimed, false, true},
      {"retimed-no-feedforward", TimingKind::kRetimed, true, false},
  };
}

namespace {

std::string short_label(const trajectory::Segment& s) {
  if (s.kind == trajectory::SegmentKind::kShape) {
    // Labels look like "program.segments[1] (shape circle)": keep the shape's name.
    const auto open = s.label.rfind(' ');
    const auto close = s.label.rfind(')');
    if (open != std::string::npos && close != std::string::npos && close > open)
      return s.label.substr(open + 1, close - open - 1);
    return "shape";
  }
  return trajectory::to_string(s.kind);
}

void accumulate(SegmentMetrics& m, const Row& row, const Row* prev, int n, double& sum_sq_err,
                double& sum_sq_internal) {
  const double ex = std::abs(row.X_d.x() - row.X.x()) * 1e3;
  const double ey = std::abs(row.X_d.y() - row.X.y()) * 1e3;
  const double e = std::hypot(ex, ey);
  m.max_error_x_mm = std::max(m.max_error_x_mm, ex);
  m.max_error_y_mm = std::max(m.max_error_y_mm, ey);
  m.max_error_mm = std::max(m.max_error_mm, e);
  sum_sq_err += e * e;
  sum_sq_internal += row.tau_internal * row.tau_internal;
  for (int i = 0; i < n; ++i) {
    m.peak_tau[i] = std::max(m.peak_tau[i], std::abs(row.tau[i]));
    if (prev) m.max_tau_step = std::max(m.max_tau_step, std::abs(row.tau[i] - prev->tau[i]));
  }
  ++m.cycles;
}

}  // namespace

void compute_metrics(const trajectory::Program& program, RunResult& r) {
  const auto& segs = program.segments();
  r.segments.assign(segs.size(), SegmentMetrics{});
  std::vector<double> sq_err(segs.size(), 0.0), sq_int(segs.size(), 0.0);
  for (std::size_t s = 0; s < segs.size(); ++s) {
    r.segments[s].segment = s;
    r.segments[s].kind = segs[s].kind;
    r.segments[s].label = short_label(segs[s]);
  }
  r.shapes = SegmentMetrics{};
  r.shapes.label = "all shapes";
  r.shapes.kind = trajectory::SegmentKind::kShape;
  double shape_sq_err = 0.0, shape_sq_int = 0.0;
  for (std::size_t k = 0; k < r.rows.size(); ++k) {
    const Row& row = r.rows[k];
    const std::size_t s = static_cast<std::size_t>(row.segment);
    if (s >= segs.size()) continue;
    const Row* prev = k > 0 ? &r.rows[k - 1] : nullptr;
    accumulate(r.segments[s], row, prev, r.n, sq_err[s], sq_int[s]);
    if (segs[s].kind == trajectory::SegmentKind::kShape)
      accumulate(r.shapes, row, prev, r.n, shape_sq_err, shape_sq_int);
  }
  for (std::size_t s = 0; s < segs.size(); ++s) {
    auto& m = r.segments[s];
    if (m.cycles > 0) {
      m.rms_error_mm = std::sqrt(sq_err[s] / m.cycles);
      m.rms_internal = std::sqrt(sq_int[s] / m.cycles);
    }
  }
  if (r.shapes.cycles > 0) {
    r.shapes.rms_error_mm = std::sqrt(shape_sq_err / r.shapes.cycles);
    r.shapes.rms_internal = std::sqrt(shape_sq_int / r.shapes.cycles);
  }
}

RunResult run_in_process(const RobotConfig& config, const trajectory::Program& program,
                         const Variant& variant, const RunOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  RunResult result;
  result.variant = variant;
  result.n = config.model.n;

  sim::Plant plant(config.model, config.plant);
  plant.reset(config.model.home);
  sim::SimActuatorSet io(plant);
  control::ControlSetup setup = config.control;
  setup.controller.projection = variant.projection;
  setup.controller.feedforward = variant.feedforward;
  const double period = config.period();
  control::ControlCycle cycle(config.model, setup, {period, 2.0});
  cycle.start(io, trajectory::with_timing(program, variant.timing), config.trajectory.rebase);
  const trajectory::Program& run_program = cycle.sequencer()->program();

  const double duration = cycle.program_duration();
  const auto total_cycles = static_cast<std::int64_t>(std::ceil((duration + options.settle_time) / period));
  result.rows.reserve(static_cast<std::size_t>(total_cycles));
  control::CycleRecord rec;
  const std::int64_t progress_every = std::max<std::int64_t>(1, static_cast<std::int64_t>(0.5 / period));
  for (std::int64_t k = 0; k < total_cycles; ++k) {
    const control::CycleStatus s = cycle.step(io, rec);
    if (s != control::CycleStatus::kOk) {
      result.ok = false;
      result.failure = fmt::format("cycle {} (t = {:.3f} s): {}", rec.cycle, rec.t, control::to_string(s));
      break;
    }
    if (plant.advance(period) != sim::PlantStatus::kOk) {
      result.ok = false;
      result.failure = fmt::format("cycle {}: simulated plant: {} ({})", rec.cycle,
                                   sim::to_string(plant.status()), model::to_string(plant.output().fault));
      break;
    }
    if (rec.phase == control::CyclePhase::kEnabling) continue;
    Row row;
    row.t = rec.t;
    row.segment = static_cast<int>(rec.ref.segment);
    row.X_d = rec.ref.cartesian.X;
    row.X = rec.est.X;
    for (int i = 0; i < result.n; ++i) row.tau[i] = rec.command.torque[i];
    row.tau_internal = rec.control.tau_internal.norm();
    row.plant_internal = plant.output().internal_norm;
    row.lambda = rec.ref.phase.lambda;
    row.lambda_dot = rec.ref.phase.lambda_dot;
    row.lambda_dd = rec.ref.phase.lambda_dd;
    result.rows.push_back(row);
    if (options.progress && k % progress_every == 0) options.progress(variant.name, rec.t, duration);
  }
  result.robot_time = static_cast<double>(result.rows.size()) * period;
  compute_metrics(run_program, result);
  result.wall_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

}  // namespace dualv::apps
