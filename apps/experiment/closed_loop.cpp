#include "apps/experiment/closed_loop.hpp"

#include <fmt/format.h>

#include <cmath>

#include "apps/experiment/machine.hpp"
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
  auto keep_max = [&row](double& max, double& t, double v) {
    if (v > max) max = v, t = row.t;
  };
  keep_max(m.max_error_x_mm, m.t_max_error_x, ex);
  keep_max(m.max_error_y_mm, m.t_max_error_y, ey);
  keep_max(m.max_error_mm, m.t_max_error, e);
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
  r.program = SegmentMetrics{};
  r.program.label = "program";
  r.program.kind = trajectory::SegmentKind::kShape;
  double shape_sq_err = 0.0, shape_sq_int = 0.0, program_sq_err = 0.0, program_sq_int = 0.0;
  for (std::size_t k = 0; k < r.rows.size(); ++k) {
    const Row& row = r.rows[k];
    const Row* prev = k > 0 ? &r.rows[k - 1] : nullptr;
    accumulate(r.program, row, prev, r.n, program_sq_err, program_sq_int);
    const std::size_t s = static_cast<std::size_t>(row.segment);
    if (s >= segs.size()) continue;
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
  if (r.program.cycles > 0) {
    r.program.rms_error_mm = std::sqrt(program_sq_err / r.program.cycles);
    r.program.rms_internal = std::sqrt(program_sq_int / r.program.cycles);
  }
}

namespace {

MachineOptions machine_options(const RunOptions& o, bool paced) {
  MachineOptions m;
  m.pacing = paced ? Pacing::kLoopThread : Pacing::kSimulated;
  m.telemetry = o.telemetry;
  m.commands = o.commands;
  m.service = o.service;
  m.fault_log_path = o.fault_log_path;
  return m;
}

// One reference on a machine of its own: started, followed, shut down.
template <typename Follow>
RunResult on_machine(const RobotConfig& config, drivers::ActuatorSet& io, sim::Plant* plant,
                     const RunOptions& options, bool paced, Follow&& follow) {
  Machine machine(config, io, machine_options(options, paced), plant);
  machine.start();
  RunResult r = follow(machine);
  r.loop = machine.shutdown().stats;
  return r;
}

// The in-process simulation of config.plant, started at home.
template <typename Follow>
RunResult in_process(const RobotConfig& config, const RunOptions& options, Follow&& follow) {
  sim::Plant plant(config.model, config.plant);
  plant.reset(config.model.home);
  sim::SimActuatorSet io(plant);
  return on_machine(config, io, &plant, options, options.realtime, follow);
}

}  // namespace

RunResult run_program(const RobotConfig& config, const trajectory::Program& program,
                      const Variant& variant, drivers::ActuatorSet& io, const RunOptions& options) {
  return on_machine(config, io, nullptr, options, true,
                    [&](Machine& m) { return m.run(program, variant, options); });
}

RunResult run_in_process(const RobotConfig& config, const trajectory::Program& program,
                         const Variant& variant, const RunOptions& options) {
  return in_process(config, options, [&](Machine& m) { return m.run(program, variant, options); });
}

RunResult run_stream(const RobotConfig& config, drivers::ActuatorSet& io,
                     const RunOptions& options) {
  return on_machine(config, io, nullptr, options, true,
                    [&](Machine& m) { return m.stream(options); });
}

RunResult run_stream_in_process(const RobotConfig& config, const RunOptions& options) {
  return in_process(config, options, [&](Machine& m) { return m.stream(options); });
}

}  // namespace dualv::apps
