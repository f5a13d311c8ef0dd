#include "apps/experiment/closed_loop.hpp"

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <memory>
#include <stdexcept>
#include <thread>

#include "control/loop/control_cycle.hpp"
#include "control/loop/periodic_executive.hpp"
#include "dualv_lcm/robot_state_t.hpp"
#include "safety/fault.hpp"
#include "safety/fault_log.hpp"
#include "safety/safety_filter.hpp"
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

std::atomic<safety::SafetyFilter*> g_active_filter{nullptr};
std::atomic<bool> g_stop_signal{false};
std::atomic<bool> g_exit_when_idle{false};
static_assert(std::atomic<bool>::is_always_lock_free);  // used from a signal handler

extern "C" void on_stop_signal(int sig) {
  g_stop_signal.store(true);
  safety::SafetyFilter* f = g_active_filter.load();
  if (!f) {
    std::signal(sig, SIG_DFL);            // a second signal ends the process
    if (g_exit_when_idle.load()) return;  // the idle --serve loop sees the flag and ends
    std::raise(sig);                      // nothing is moving: leave as the signal's default would
    return;
  }
  f->request_stop(safety::StopSource::kSignal);  // lock-free, async-signal-safe
  std::signal(sig, SIG_DFL);                     // a second signal ends the process
}

// Drains the safety fault log off the RT thread: to a JSON-lines file and to telemetry.
class FaultLogDrain {
 public:
  FaultLogDrain(safety::FaultLog& log, const RunOptions& options) : log_(log), options_(options) {
    if (!options.fault_log_path.empty())
      writer_ = std::make_unique<safety::FaultLogWriter>(options.fault_log_path);
    if (writer_ || options.telemetry) thread_ = std::thread([this] { loop(); });
  }
  ~FaultLogDrain() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    drain();
  }

 private:
  void loop() {
    while (!stop_) {
      drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  void drain() {
    auto publish = [this](const safety::FaultEvent& e) {
      if (!options_.telemetry) return;
      runtime::FaultSample f;
      f.utime = runtime::wall_utime();
      f.cycle = e.cycle;
      runtime::copy_text(f.cause, e.fault == safety::Fault::kCount ? safety::to_string(e.kind)
                                                                   : safety::to_string(e.fault));
      runtime::copy_text(f.reaction, safety::to_string(e.reaction));
      f.node = e.drive;
      f.detection_latency_cycles = e.latency_cycles;
      f.n = e.n;
      for (int i = 0; i < e.n && i < runtime::kMaxJoints; ++i) f.tau_at_detection[i] = e.torque[i];
      runtime::copy_text(f.text, safety::describe(e));
      options_.telemetry->push_fault(f);
    };
    if (writer_) {
      writer_->drain(log_, publish);
    } else {
      safety::FaultEvent e;
      while (log_.try_pop(e)) publish(e);
    }
  }
  safety::FaultLog& log_;
  const RunOptions& options_;
  std::unique_ptr<safety::FaultLogWriter> writer_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// One cycle as a telemetry sample (noexcept, no allocation: a copy into fixed arrays).
runtime::StateSample state_sample(const control::CycleRecord& rec,
                                  const control::ControlCycle& cycle, int n, double period,
                                  bool simulated) noexcept {
  using M = dualv_lcm::robot_state_t;
  runtime::StateSample s;
  s.utime = runtime::wall_utime();
  s.cycle = rec.cycle;
  s.t = rec.t;
  s.n = static_cast<std::int16_t>(n);
  for (int i = 0; i < n && i < runtime::kMaxJoints; ++i) {
    s.q[i] = rec.est.q[i];
    s.q_dot[i] = rec.est.q_dot[i];
    s.tau_cmd[i] = rec.command.torque[i];
    s.tau_internal[i] = rec.control.tau_internal.size() > i ? rec.control.tau_internal[i] : 0.0;
  }
  for (int k = 0; k < 3; ++k) {
    s.X[k] = rec.est.X[k];
    s.X_d[k] = rec.ref.cartesian.X[k];
    s.tracking_error[k] = rec.ref.cartesian.X[k] - rec.est.X[k];
  }
  s.lambda = rec.ref.phase.lambda;
  s.segment = static_cast<std::int32_t>(rec.ref.segment);
  const bool running = rec.phase == control::CyclePhase::kRunning;
  s.safety_state = safety::telemetry_state(rec.safety);
  runtime::copy_text(s.safety_text, safety::to_string(rec.safety.state));
  s.status_flags = (simulated ? M::FLAG_SIMULATED : 0) | (running ? M::FLAG_PROGRAM_RUNNING : 0) |
                   (rec.safety.latched ? M::FLAG_ESTOP_LATCHED : 0);
  if (const trajectory::StreamingReference* ref = cycle.stream()) {
    if (cycle.streaming() && rec.safety.state == safety::SafetyState::kOperational) {
      s.status_flags |= M::FLAG_STREAMING;
      s.stream_age = cycle.safety().stream_age_cycles() * period;
    }
    for (int k = 0; k < 3; ++k) s.stream_target[k] = ref->target()[k];
    s.stream_accepted = static_cast<std::int64_t>(ref->accepted());
    s.stream_refused = static_cast<std::int64_t>(ref->refused());
  }
  return s;
}

}  // namespace

void install_stop_signal_handlers(bool exit_when_idle) {
  g_exit_when_idle = exit_when_idle;
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
}

bool stop_signal_received() noexcept { return g_stop_signal.load(); }

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

// One closed-loop run; the reference is `program` or, when null, a stream of setpoints.
RunResult run_loop(const RobotConfig& config, const trajectory::Program* program,
                   const Variant& variant, drivers::ActuatorSet& io, const RunOptions& options,
                   const std::function<double()>& after_cycle) {
  const auto wall_start = std::chrono::steady_clock::now();
  RunResult result;
  result.variant = variant;
  result.n = config.model.n;
  const bool stream = program == nullptr;
  if (stream && !options.commands)
    throw std::invalid_argument("a streaming run needs a command channel for its setpoints");
  result.stream.streamed = stream;

  control::ControlSetup setup = config.control;
  setup.controller.projection = variant.projection;
  setup.controller.feedforward = variant.feedforward;
  const double period = config.period();
  control::ControlCycle cycle(config.model, setup, {period, 2.0, config.safety});
  if (stream)
    cycle.start_streaming(io, config.trajectory.streaming, config.trajectory.limits.workspace);
  else
    cycle.start(io, trajectory::with_timing(*program, variant.timing), config.trajectory.rebase);
  const trajectory::Program run_program =
      stream ? trajectory::Program(config.model.home) : cycle.sequencer()->program();
  const double duration = stream ? options.max_stream_time : cycle.program_duration();
  const auto total_cycles =
      static_cast<std::int64_t>(std::ceil((duration + options.settle_time) / period));
  // No allocation in the loop: a program's rows are all kept; a stream's up to a bound.
  const std::int64_t row_capacity =
      stream ? std::min(total_cycles, std::max<std::int64_t>(options.max_stream_rows, 1))
             : total_cycles;
  result.rows.reserve(static_cast<std::size_t>(row_capacity));
  const auto settle_cycles = static_cast<std::int64_t>(std::ceil(options.settle_time / period));
  std::int64_t stream_end_cycle = -1;  // loop cycle of the signed stop that ended the stream

  // Simulated time: the schedule jumps, the cycle work is still timed on the real clock.
  // Only a simulation advanced by after_cycle may run on it: drives on a bus (no
  // after_cycle) answer each SYNC in real time, so their loop is always paced by the clock.
  const bool paced = options.realtime || !after_cycle;
  control::SimClock sim_clock;
  control::MonotonicClock mono;
  control::ExecutiveConfig exec = config.loop;
  exec.realtime = paced;
  control::PeriodicExecutive executive(
      exec,
      paced ? static_cast<control::LoopClock&>(mono) : static_cast<control::LoopClock&>(sim_clock),
      &mono);
  FaultLogDrain fault_drain(cycle.safety().log(), options);
  g_active_filter = &cycle.safety();
  // A signal that came before the filter was registered above (while this run was being
  // set up) found no run to stop: stop this one. Checked after registering, so a signal is
  // seen here or by the handler, never by neither.
  if (g_stop_signal.load()) cycle.safety().request_stop(safety::StopSource::kSignal);
  struct Deactivate {
    ~Deactivate() { g_active_filter = nullptr; }
  } deactivate;
  control::CycleRecord rec;
  const bool simulated = static_cast<bool>(after_cycle);
  const std::int64_t progress_every = std::max<std::int64_t>(1, std::llround(0.5 / period));
  bool failed = false;
  control::CycleRecord failure_record;  // the cycle that first failed (copied once, set-up size)
  std::uint64_t estops_seen = options.commands ? options.commands->estop_requests() : 0;
  // Operator commands from LCM: an e-stop is never lost (a counter), stop and reset are queued.
  auto take_commands = [&]() noexcept {
    if (!options.commands) return;
    const std::uint64_t estops = options.commands->estop_requests();
    if (estops != estops_seen) cycle.safety().request_stop(safety::StopSource::kLcm);
    estops_seen = estops;
    runtime::VerifiedCommand cmd;
    while (options.commands->try_pop(cmd)) {
      // A stop ends a stream normally (hold); it stops a program with SS1.
      if (cmd.kind == runtime::CommandKind::kStop && stream) {
        cycle.end_stream();
        result.stream.ended_by_stop = true;
      } else if (cmd.kind == runtime::CommandKind::kStop) {
        cycle.safety().request_stop(safety::StopSource::kLcm);
      }
      if (cmd.kind == runtime::CommandKind::kReset) cycle.safety().request_reset();
    }
    // Setpoints are absolute poses: each one replaces the last, so all are handed on in
    // order; the reference refuses (and counts) bad ones, the accepted feed the watchdog.
    runtime::VerifiedSetpoint sp;
    while (options.commands->try_pop_setpoint(sp)) {
      if (stream)
        cycle.stream_setpoint(model::Pose(sp.x, sp.y, sp.theta));
      else
        ++result.stream.ignored;
    }
  };
  auto fn = [&](const control::CycleInfo& info) noexcept -> control::CycleResult {
    if (options.service) options.service->beat();  // the watchdog's proof of life
    take_commands();
    if (stream && result.stream.ended_by_stop && stream_end_cycle < 0)
      stream_end_cycle = info.cycle;
    cycle.note_timing(info.skipped_releases > 0, info.consecutive_misses);
    const control::CycleStatus s = cycle.step(io, rec);
    // Every cycle, stops included: the operator watches an SS1 ramp or an STO on telemetry.
    if (options.telemetry)
      options.telemetry->push_state(state_sample(rec, cycle, result.n, period, simulated));
    const double internal = after_cycle ? after_cycle() : std::nan("");
    if (after_cycle && std::isnan(internal)) {  // the simulated plant itself failed
      failed = true;
      return control::CycleResult::kStop;
    }
    if (s != control::CycleStatus::kOk) {
      // Keep cycling while the safety filter brings the machine to rest (SS1): the stop is
      // carried out by this loop, not by the drives' timeouts. Stop once torque is off.
      if (!failed) failure_record = rec;
      failed = true;
      const bool torque_off = rec.safety.state == safety::SafetyState::kSto ||
                              rec.safety.state == safety::SafetyState::kDisabled;
      return torque_off || s != control::CycleStatus::kSafetyStop ? control::CycleResult::kStop
                                                                  : control::CycleResult::kContinue;
    }
    if (failed) return control::CycleResult::kContinue;
    if (rec.phase == control::CyclePhase::kEnabling) return control::CycleResult::kContinue;
    Row row;
    row.t = rec.t;
    row.segment = static_cast<int>(rec.ref.segment);
    row.X_d = rec.ref.cartesian.X;
    row.X = rec.est.X;
    for (int i = 0; i < result.n; ++i) row.tau[i] = rec.command.torque[i];
    row.tau_internal = rec.control.tau_internal.norm();
    row.plant_internal = internal;
    row.lambda = rec.ref.phase.lambda;
    row.lambda_dot = rec.ref.phase.lambda_dot;
    row.lambda_dd = rec.ref.phase.lambda_dd;
    if (result.rows.size() < result.rows.capacity()) result.rows.push_back(row);
    if (stream)  // held for settle_time after a normal end, else until max_stream_time
      return (stream_end_cycle >= 0 && info.cycle >= stream_end_cycle + settle_cycles) ||
                     info.cycle >= total_cycles
                 ? control::CycleResult::kStop
                 : control::CycleResult::kContinue;
    return result.rows.size() < result.rows.capacity() ? control::CycleResult::kContinue
                                                       : control::CycleResult::kStop;
  };
  auto with_progress = [&](const control::CycleInfo& info) noexcept -> control::CycleResult {
    if (options.before_cycle) {  // tests and simulations only (RunOptions)
      try {
        options.before_cycle(info.cycle);
      } catch (...) {
      }
    }
    const control::CycleResult r = fn(info);
    // Progress is set-up code's business: called between cycles, it may print.
    if (options.progress && info.cycle % progress_every == 0) {
      try {
        options.progress(variant.name, rec.t, duration);
      } catch (...) {
      }
    }
    return r;
  };
  // A failing enable phase must end too: bound the run to enabling time + program + settle.
  const control::RunReport report =
      executive.run(with_progress, total_cycles + std::llround(2.0 / period) + 1);
  // Leave the drives disabled with zero torque (CiA 402 disable voltage), whatever the end:
  // drives left in Operation enabled would otherwise wait for RPDOs that no longer come.
  drivers::ActuatorCommand off;
  off.n = result.n;
  off.request = drivers::DriveRequest::kDisable;
  for (int k = 0; k < 3; ++k) {
    io.write(off);
    if (paced) std::this_thread::sleep_for(std::chrono::duration<double>(period));
  }
  result.loop = report.stats;
  if (options.telemetry) {
    runtime::LoopStatsSample ls;
    ls.stats = report.stats;
    ls.realtime = paced;
    ls.telemetry_dropped = static_cast<std::int64_t>(options.telemetry->dropped());
    options.telemetry->push_loop_stats(ls);
  }
  if (failed) {
    const control::CycleRecord& bad = failure_record.cycle > 0 ? failure_record : rec;
    result.ok = false;
    result.failure = fmt::format("cycle {} (t = {:.3f} s): {}", bad.cycle, bad.t,
                                 control::to_string(bad.status));
    std::string causes;
    for (int f = 0; f < safety::kFaultCount; ++f)
      if (bad.safety.latched & safety::bit(static_cast<safety::Fault>(f)))
        causes += std::string(causes.empty() ? "" : ", ") +
                  safety::to_string(static_cast<safety::Fault>(f));
    if (!causes.empty()) result.failure += " (" + causes + ")";
    result.failure += fmt::format("; stopped with the safety state {} at cycle {}",
                                  safety::to_string(rec.safety.state), rec.cycle);
  }
  result.robot_time = static_cast<double>(result.rows.size()) * period;
  if (const trajectory::StreamingReference* ref = cycle.stream()) {
    result.stream.accepted = ref->accepted();
    result.stream.refused = ref->refused();
  }
  compute_metrics(run_program, result);
  result.wall_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

// The in-process simulation of config.plant, started at home, around `run`.
RunResult with_plant(
    const RobotConfig& config,
    const std::function<RunResult(drivers::ActuatorSet&, const std::function<double()>&)>& run) {
  sim::Plant plant(config.model, config.plant);
  plant.reset(config.model.home);
  sim::SimActuatorSet io(plant);
  const double period = config.period();
  RunResult r = run(io, [&]() noexcept {
    return plant.advance(period) == sim::PlantStatus::kOk ? plant.output().internal_norm
                                                          : std::nan("");
  });
  if (plant.status() != sim::PlantStatus::kOk) {
    r.ok = false;
    r.failure = fmt::format("simulated plant: {} ({})", sim::to_string(plant.status()),
                            model::to_string(plant.output().fault));
  }
  return r;
}

}  // namespace

RunResult run_program(const RobotConfig& config, const trajectory::Program& program,
                      const Variant& variant, drivers::ActuatorSet& io, const RunOptions& options,
                      const std::function<double()>& after_cycle) {
  return run_loop(config, &program, variant, io, options, after_cycle);
}

RunResult run_in_process(const RobotConfig& config, const trajectory::Program& program,
                         const Variant& variant, const RunOptions& options) {
  return with_plant(config, [&](drivers::ActuatorSet& io, const std::function<double()>& after) {
    return run_program(config, program, variant, io, options, after);
  });
}

RunResult run_stream(const RobotConfig& config, drivers::ActuatorSet& io, const RunOptions& options,
                     const std::function<double()>& after_cycle) {
  Variant v = paper_variants().front();
  v.name = "stream";
  return run_loop(config, nullptr, v, io, options, after_cycle);
}

RunResult run_stream_in_process(const RobotConfig& config, const RunOptions& options) {
  return with_plant(config, [&](drivers::ActuatorSet& io, const std::function<double()>& after) {
    return run_stream(config, io, options, after);
  });
}

}  // namespace dualv::apps
