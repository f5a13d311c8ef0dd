#include "apps/experiment/machine.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <stdexcept>
#include <thread>

#include "common/spsc_queue.hpp"
#include "dualv_lcm/robot_state_t.hpp"
#include "safety/fault.hpp"
#include "safety/fault_log.hpp"

namespace dualv::apps {

namespace {

// --- SIGINT / SIGTERM ---------------------------------------------------------------------
std::atomic<control::Executor*> g_active_executor{nullptr};
std::atomic<bool> g_stop_signal{false};
std::atomic<bool> g_exit_when_idle{false};
static_assert(std::atomic<bool>::is_always_lock_free);  // used from a signal handler
static_assert(std::atomic<control::Executor*>::is_always_lock_free);

extern "C" void on_stop_signal(int sig) {
  g_stop_signal.store(true);
  control::Executor* ex = g_active_executor.load();
  std::signal(sig, SIG_DFL);  // a second signal ends the process
  if (ex == nullptr) {
    if (g_exit_when_idle.load()) return;  // the --serve supervisor sees the flag and ends
    std::raise(sig);                      // no loop runs: leave as the signal's default would
    return;
  }
  ex->request_estop(safety::StopSource::kSignal);  // lock-free, async-signal-safe
}

// One cycle as the supervisor records it: plain data for the lock-free queue.
struct CycleSample {
  std::uint64_t id = 0;  // reference followed (0: none)
  std::int64_t cycle = 0;
  double t = 0.0;
  control::CyclePhase phase = control::CyclePhase::kIdle;
  control::CycleStatus status = control::CycleStatus::kOk;
  safety::SafetyState safety = safety::SafetyState::kDisabled;
  std::uint32_t latched = 0;
  std::int32_t segment = 0;
  double X_d[3] = {0.0, 0.0, 0.0};
  double X[3] = {0.0, 0.0, 0.0};
  double tau[drivers::kMaxDrives] = {};
  double tau_internal = 0.0;
  double plant_internal = 0.0;
  double lambda = 0.0, lambda_dot = 0.0, lambda_dd = 0.0;
  std::uint64_t stream_accepted = 0, stream_refused = 0;  // the stream followed, if any
};

// One cycle as a telemetry sample (noexcept, no allocation: a copy into fixed arrays).
runtime::StateSample state_sample(const control::CycleRecord& rec, const control::Executor& ex,
                                  int n, double period, bool simulated) noexcept {
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
  const bool running =
      ex.mode() == control::LoopMode::kProgram && rec.phase == control::CyclePhase::kRunning;
  s.safety_state = safety::telemetry_state(rec.safety);
  runtime::copy_text(s.safety_text, safety::to_string(rec.safety.state));
  s.status_flags = (simulated ? M::FLAG_SIMULATED : 0) | (running ? M::FLAG_PROGRAM_RUNNING : 0) |
                   (rec.safety.latched ? M::FLAG_ESTOP_LATCHED : 0);
  const control::ControlCycle& cycle = ex.cycle();
  if (const trajectory::StreamingReference* ref = cycle.stream();
      ref && ex.mode() == control::LoopMode::kStream) {
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

// --- what runs inside the cycle -----------------------------------------------------------
class Machine::Hooks final : public control::LoopHooks {
 public:
  static constexpr std::size_t kSamples = 4096;  // 4 s at 1 kHz of supervisor stall
  Hooks(const RobotConfig& config, const MachineOptions& options, sim::Plant* plant)
      : n_(config.model.n),
        period_(config.period()),
        idle_every_(std::max<std::int64_t>(1, std::llround(0.02 / config.period()))),
        loud_cycles_(std::llround(1.0 / config.period())),
        options_(options),
        plant_(plant) {}

  void before_cycle(control::Executor& ex, const control::CycleInfo& info) noexcept override {
    // The drives' reads and writes of this cycle take its wake-up as their time (one clock
    // read less per cycle: drivers/canopen/cycle_clock.hpp).
    if (options_.cycle_clock)
      options_.cycle_clock->begin_cycle(static_cast<std::uint64_t>(info.wake_ns));
    if (options_.service) options_.service->beat();  // the watchdog's proof of life
    if (!options_.commands) return;
    // Setpoints are absolute poses: each replaces the last, so all are handed on in order;
    // the reference refuses (and counts) bad ones. While no stream runs they move nothing.
    runtime::VerifiedSetpoint sp;
    while (options_.commands->try_pop_setpoint(sp)) {
      if (ex.mode() == control::LoopMode::kStream)
        ex.stream_setpoint(model::Pose(sp.x, sp.y, sp.theta));
      else
        ignored_.fetch_add(1, std::memory_order_relaxed);
    }
  }

  void after_cycle(const control::Executor& ex, const control::CycleRecord& rec,
                   const control::CycleInfo& info) noexcept override {
    if (options_.cycle_clock) options_.cycle_clock->end_cycle();
    double internal = std::nan("");
    if (plant_ && !failed_.load(std::memory_order_relaxed)) {
      if (plant_->advance(period_) == sim::PlantStatus::kOk)
        internal = plant_->output().internal_norm;
      else
        failed_.store(true, std::memory_order_release);
    }
    // Telemetry every cycle while anything moves or stops and for a second after a stop came
    // to torque off, 50 Hz idle (a service is on for weeks: its log must not grow by a sample
    // a millisecond while nothing happens).
    sto_cycles_ = rec.safety.state == safety::SafetyState::kSto ? sto_cycles_ + 1 : 0;
    const bool quiet = (ex.mode() == control::LoopMode::kIdle &&
                        rec.safety.state == safety::SafetyState::kDisabled) ||
                       sto_cycles_ > loud_cycles_;
    if (options_.telemetry && (!quiet || info.cycle % idle_every_ == 0))
      options_.telemetry->push_state(state_sample(rec, ex, n_, period_, plant_ != nullptr));
    CycleSample s;
    s.id = ex.reference_id();
    s.cycle = rec.cycle;
    s.t = rec.t;
    s.phase = rec.phase;
    s.status = rec.status;
    s.safety = rec.safety.state;
    s.latched = rec.safety.latched;
    s.segment = static_cast<std::int32_t>(rec.ref.segment);
    for (int k = 0; k < 3; ++k) {
      s.X_d[k] = rec.ref.cartesian.X[k];
      s.X[k] = rec.est.X[k];
    }
    for (int i = 0; i < n_; ++i) s.tau[i] = rec.command.torque[i];
    s.tau_internal = rec.control.tau_internal.norm();
    s.plant_internal = internal;
    s.lambda = rec.ref.phase.lambda;
    s.lambda_dot = rec.ref.phase.lambda_dot;
    s.lambda_dd = rec.ref.phase.lambda_dd;
    if (const trajectory::StreamingReference* ref = ex.cycle().stream();
        ref && ex.mode() == control::LoopMode::kStream) {
      s.stream_accepted = ref->accepted();
      s.stream_refused = ref->refused();
    }
    samples_.try_push(s);
  }

  SpscQueue<CycleSample, kSamples>& samples() noexcept { return samples_; }
  bool failed() const noexcept { return failed_.load(std::memory_order_acquire); }
  std::uint64_t ignored() const noexcept { return ignored_.load(std::memory_order_relaxed); }

 private:
  int n_;
  double period_;
  std::int64_t idle_every_;
  std::int64_t loud_cycles_;
  std::int64_t sto_cycles_ = 0;
  const MachineOptions& options_;
  sim::Plant* plant_;
  SpscQueue<CycleSample, kSamples> samples_;
  std::atomic<bool> failed_{false};
  std::atomic<std::uint64_t> ignored_{0};
};

// Drains the safety fault log off the RT thread: to a JSON-lines file and to telemetry.
class Machine::Drain {
 public:
  Drain(safety::FaultLog& log, const MachineOptions& options) : log_(log), options_(options) {
    if (!options.fault_log_path.empty())
      writer_ = std::make_unique<safety::FaultLogWriter>(options.fault_log_path);
    if (writer_ || options.telemetry) thread_ = std::thread([this] { loop(); });
  }
  ~Drain() {
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
  const MachineOptions& options_;
  std::unique_ptr<safety::FaultLogWriter> writer_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// --- the machine ----------------------------------------------------------------------------
Machine::Machine(const RobotConfig& config, drivers::ActuatorSet& io, const MachineOptions& options,
                 sim::Plant* plant, std::unique_ptr<control::LoopThread> launched)
    : config_(config), io_(io), options_(options), plant_(plant) {
  if (options.pacing == Pacing::kSimulated && plant == nullptr)
    throw std::invalid_argument("a machine on drives is paced by the clock (MachineOptions)");
  control::ExecutorConfig ec;
  ec.cycle = {config.period(), 2.0, config.safety};
  ec.idle = config.loop.idle_hold ? control::IdleMode::kHold : control::IdleMode::kDisabled;
  hooks_ = std::make_unique<Hooks>(config, options_, plant);
  executor_ = std::make_unique<control::Executor>(config.model, config.control, ec, io);
  executor_->set_hooks(hooks_.get());
  if (options.commands) executor_->watch_estops(&options.commands->estop_counter());
  control::ExecutiveConfig exec = config.loop;
  exec.realtime = paced();
  if (options.pacing == Pacing::kLoopThread && launched) {
    thread_ = std::move(launched);
  } else if (options.pacing == Pacing::kLoopThread) {
    thread_ = std::make_unique<control::LoopThread>(exec, mono_, &mono_);
    const control::RealtimeStatus& rt = thread_->launch();  // SCHED_FIFO etc. on its thread
    if (options.on_realtime) options.on_realtime(rt);
  } else if (options.pacing == Pacing::kCallerThread) {
    if (options.memory_locked) exec.lock_memory = false;
    stepper_ = std::make_unique<control::PeriodicExecutive>(exec, mono_);
  } else {
    stepper_ = std::make_unique<control::PeriodicExecutive>(exec, sim_clock_, &mono_);
  }
}

Machine::~Machine() {
  try {
    shutdown();
  } catch (...) {
  }
}

void Machine::start() {
  if (started_) return;
  started_ = true;
  g_active_executor = executor_.get();
  // A signal that came before the loop was registered (while the drives booted) stops it.
  if (g_stop_signal.load()) executor_->request_estop(safety::StopSource::kSignal);
  if (thread_) {
    thread_->go(*executor_);
    // Set-up that may take a while (a thread: its stack is locked under mlockall) comes after
    // the first cycle: the drives' deadlines run from the priming on.
    drain_ = std::make_unique<Drain>(executor_->safety().log(), options_);
    while (executor_->snapshot().cycle < 0 && thread_->running()) pump();
  } else {
    stepper_->begin();
    pump();  // the first cycle: the pose is known from here on
    // After it: a new thread's stack is locked and faulted in under mlockall (slow on a small
    // target), and the drives' deadlines run from the priming on.
    drain_ = std::make_unique<Drain>(executor_->safety().log(), options_);
    if (options_.on_realtime) options_.on_realtime(stepper_->realtime_status());
  }
}

bool Machine::plant_failed() const noexcept { return hooks_->failed(); }

std::string Machine::plant_failure() const {
  if (!plant_ || plant_->status() == sim::PlantStatus::kOk) return {};
  return fmt::format("simulated plant: {} ({})", sim::to_string(plant_->status()),
                     model::to_string(plant_->output().fault));
}

std::uint64_t Machine::setpoints_ignored() const noexcept { return hooks_->ignored(); }

control::LoopStatsSummary Machine::loop_stats() const {
  if (stepper_) return stepper_->stats().summary();
  return report_.stats;
}

void Machine::pump() {
  if (stepper_ && !ended_) {
    // Tests and simulations only (RunOptions::before_cycle): the cycle about to run, counted
    // from the one that takes the reference.
    const std::int64_t next = executor_->snapshot().cycle + 1;
    if (before_cycle_ && before_base_ >= 0 && next >= before_base_)
      before_cycle_(next - before_base_);
    const control::CycleInfo& info = stepper_->next();
    if (info.cycle == 0) first_ns_ = info.wake_ns;
    const control::CycleResult r = executor_->step(info);
    stepper_->done();
    if (r == control::CycleResult::kStop) ended_ = true;
  } else if (thread_) {
    // The supervisor looks every few cycles (its queues hold seconds): a wake-up a
    // millisecond would cost the loop's CPU on a small target (and in a test guest).
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  executor_->collect();
}

std::uint64_t Machine::take(
    const std::function<std::unique_ptr<control::PreparedReference>(std::uint64_t)>& prepare) {
  // The e-stop count when the start was asked for: one that comes during preparation
  // refuses it in the loop.
  const std::uint64_t epoch = executor_->estop_epoch();
  for (int attempt = 0;; ++attempt) {
    std::unique_ptr<control::PreparedReference> ref = prepare(epoch);
    before_base_ = executor_->snapshot().cycle + 1;  // stepped: the cycle that takes it
    const std::uint64_t id = executor_->start(std::move(ref));
    if (id == 0) throw std::runtime_error("the control loop's command queue is full");
    for (;;) {
      control::LoopEvent e;
      if (!executor_->poll_event(e)) {
        if (ended_ || (thread_ && !thread_->running()))
          throw std::runtime_error("the control loop has ended");
        pump();
        continue;
      }
      if (e.id != id) continue;
      if (e.kind == control::LoopEvent::Kind::kStarted) return id;
      if (e.kind == control::LoopEvent::Kind::kRefused) {
        // Moved between preparation and take-over (e.g. still coasting to rest): again.
        if (e.reason == control::RefuseReason::kMoved && attempt < 20) break;
        // A latched stop is named: a stop may have latched after the caller last looked
        // (e.g. a timing watchdog while idle), and its cause is what the operator must fix.
        const std::uint32_t latched = executor_->snapshot().latched;
        throw std::runtime_error(std::string("the control loop refused the start: ") +
                                 control::to_string(e.reason) +
                                 (e.reason == control::RefuseReason::kLatched && latched != 0
                                      ? " (latched: " + safety::describe_faults(latched) + ")"
                                      : std::string()));
      }
    }
    for (int k = 0; k < 10; ++k) pump();
  }
}

std::uint64_t Machine::begin(const trajectory::Program& program, const Variant& variant,
                             double settle_time, trajectory::Program* rebased) {
  if (!started_) start();
  const trajectory::Program timed = trajectory::with_timing(program, variant.timing);
  return take([&](std::uint64_t epoch) {
    auto ref = executor_->prepare_program(timed, config_.trajectory.rebase, epoch);
    ref->projection = variant.projection;
    ref->feedforward = variant.feedforward;
    ref->settle_time = settle_time;
    ref->name = variant.name;
    if (rebased) *rebased = ref->sequencer->program();  // before the loop owns it
    return ref;
  });
}

RunResult Machine::run(const trajectory::Program& program, const Variant& variant,
                       const RunOptions& options) {
  const BeforeCycleScope scope(*this, options.before_cycle);
  trajectory::Program rebased;
  const std::uint64_t id = begin(program, variant, options.settle_time, &rebased);
  return follow(id, rebased, rebased.duration(), variant, options, false);
}

RunResult Machine::stream(const RunOptions& options) {
  if (!options.commands)
    throw std::invalid_argument("a streaming run needs a command channel for its setpoints");
  const BeforeCycleScope scope(*this, options.before_cycle);
  if (!started_) start();
  Variant v = paper_variants().front();
  v.name = "stream";
  const std::uint64_t id = take([&](std::uint64_t epoch) {
    auto ref = executor_->prepare_stream(config_.trajectory.streaming,
                                         config_.trajectory.limits.workspace, epoch);
    ref->settle_time = options.settle_time;
    ref->name = "stream";
    return ref;
  });
  return follow(id, trajectory::Program(config_.model.home), options.max_stream_time, v, options,
                true);
}

RunResult Machine::follow(std::uint64_t id, const trajectory::Program& program, double duration,
                          const Variant& variant, const RunOptions& options, bool stream) {
  const auto wall_start = std::chrono::steady_clock::now();
  RunResult result;
  result.variant = variant;
  result.n = config_.model.n;
  result.stream.streamed = stream;
  const double period = config_.period();
  const auto total_cycles =
      static_cast<std::int64_t>(std::ceil((duration + options.settle_time) / period));
  result.rows.reserve(static_cast<std::size_t>(
      stream ? std::min(total_cycles, std::max<std::int64_t>(options.max_stream_rows, 1))
             : total_cycles));
  // Longest the supervisor waits: enabling, the reference, settling and a full SS1.
  const std::int64_t bound =
      total_cycles + std::llround((2.0 + config_.safety.ss1.max_time + 1.0) / period) + 1;
  const std::uint64_t ignored_before = hooks_->ignored();
  const std::int64_t progress_every = std::max<std::int64_t>(1, std::llround(0.5 / period));

  bool ended = false, failed = false, torque_off = false, asked_to_stop = false;
  CycleSample failure{}, last{};
  bool have_failure = false;
  std::int64_t last_progress = -progress_every;
  std::uint64_t stream_accepted = 0, stream_refused = 0;
  auto consume = [&](const CycleSample& s) {
    if (s.id != id) return;
    if (result.first_cycle < 0) result.first_cycle = s.cycle;
    last = s;
    stream_accepted = std::max(stream_accepted, s.stream_accepted);
    stream_refused = std::max(stream_refused, s.stream_refused);
    if (s.status != control::CycleStatus::kOk && !have_failure) {
      failure = s;
      have_failure = true;
      failed = true;
    }
    if (failed || s.phase == control::CyclePhase::kEnabling) return;
    if (result.rows.size() >= result.rows.capacity()) return;
    Row row;
    row.t = s.t;
    row.segment = s.segment;
    row.X_d = model::Pose(s.X_d[0], s.X_d[1], s.X_d[2]);
    row.X = model::Pose(s.X[0], s.X[1], s.X[2]);
    for (int i = 0; i < result.n; ++i) row.tau[i] = s.tau[i];
    row.tau_internal = s.tau_internal;
    row.plant_internal = s.plant_internal;
    row.lambda = s.lambda;
    row.lambda_dot = s.lambda_dot;
    row.lambda_dd = s.lambda_dd;
    result.rows.push_back(row);
  };
  auto drain = [&] {
    CycleSample s;
    while (hooks_->samples().try_pop(s)) consume(s);
  };
  auto commands = [&] {
    if (!options.commands) return;
    runtime::VerifiedCommand cmd;
    while (options.commands->try_pop(cmd)) {
      // A stop ends a stream normally (hold); it stops a program with SS1.
      if (cmd.kind == runtime::CommandKind::kStop) {
        executor_->submit(control::LoopCommand::Kind::kStop);
        if (stream) result.stream.ended_by_stop = true;
      }
      if (cmd.kind == runtime::CommandKind::kReset)
        executor_->submit(control::LoopCommand::Kind::kReset);
    }
  };
  std::int64_t cycles = 0;
  while (!(ended && (!failed || torque_off))) {
    pump();
    ++cycles;
    commands();
    drain();
    control::LoopEvent e;
    while (executor_->poll_event(e)) {
      if (e.kind == control::LoopEvent::Kind::kFinished && e.id == id) ended = true;
      if (e.kind == control::LoopEvent::Kind::kStopped && e.id == id) ended = failed = true;
      if (e.kind == control::LoopEvent::Kind::kTorqueOff && failed) torque_off = true;
    }
    if (failed && ended && !torque_off) {
      const safety::SafetyState st = executor_->snapshot().safety;
      torque_off = st == safety::SafetyState::kSto || st == safety::SafetyState::kDisabled;
    }
    if (options.progress && last.cycle - last_progress >= progress_every && last.id == id) {
      last_progress = last.cycle;
      options.progress(variant.name, last.t, duration);
    }
    if (hooks_->failed() && !failed) {
      failed = true;
      ended = torque_off = true;  // the simulation itself broke: nothing to wait for
    }
    if (stream && !asked_to_stop && last.t >= options.max_stream_time) {
      asked_to_stop = true;  // the longest a stream may last: end it normally
      executor_->submit(control::LoopCommand::Kind::kEndStream);
    }
    if (ended_ || (thread_ && !thread_->running())) break;
    if (cycles > bound * (stepper_ ? 1 : 2) + 10000) {
      failed = true;
      result.failure = "the reference did not end in time";
      executor_->submit(control::LoopCommand::Kind::kStop);
      break;
    }
  }
  // The last cycles' samples (paced: pushed right after the event).
  if (thread_) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  drain();
  result.loop = loop_stats();
  if (failed) {
    result.ok = false;
    if (hooks_->failed()) {
      result.failure = plant_failure();
    } else if (result.failure.empty()) {
      const CycleSample& bad = have_failure ? failure : last;
      result.failure = fmt::format("cycle {} (t = {:.3f} s): {}", bad.cycle, bad.t,
                                   control::to_string(bad.status));
      const std::string causes = safety::describe_faults(bad.latched | last.latched);
      if (!causes.empty()) result.failure += " (" + causes + ")";
      const control::LoopSnapshot snap = executor_->snapshot();
      result.failure += fmt::format("; stopped with the safety state {} at cycle {}",
                                    safety::to_string(snap.safety), snap.cycle);
    }
  }
  result.robot_time = static_cast<double>(result.rows.size()) * period;
  if (stream) {
    // The stream reference's counters as the last cycle that followed it saw them.
    result.stream.accepted = stream_accepted;
    result.stream.refused = stream_refused;
    result.stream.ignored = hooks_->ignored() - ignored_before;
  }
  compute_metrics(program, result);
  result.wall_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

control::RunReport Machine::shutdown() {
  if (!started_ || shut_down_) {
    g_active_executor = nullptr;
    return report_;
  }
  shut_down_ = true;
  executor_->submit(control::LoopCommand::Kind::kShutdown);
  const auto limit = std::chrono::steady_clock::now() +
                     std::chrono::duration<double>(config_.safety.ss1.max_time + 5.0);
  if (thread_) {
    while (thread_->running() && std::chrono::steady_clock::now() < limit) pump();
    thread_->stop();  // ends the loop if the executor did not (a stuck stop)
    report_ = thread_->join();
    thread_.reset();
  } else {
    const std::int64_t max_cycles =
        std::llround((config_.safety.ss1.max_time + 1.0) / config_.period());
    for (std::int64_t k = 0; k < max_cycles && !ended_; ++k) pump();
    report_ = stepper_->end();
    stepper_->release_realtime();  // kCallerThread: the caller goes on with normal scheduling
    ended_ = true;
  }
  g_active_executor = nullptr;
  CycleSample s;
  while (hooks_->samples().try_pop(s)) {
  }
  executor_->collect();
  // Leave the drives disabled with zero torque (CiA 402 disable voltage), whatever the end.
  drivers::ActuatorCommand off;
  off.n = config_.model.n;
  off.request = drivers::DriveRequest::kDisable;
  for (int k = 0; k < 3; ++k) {
    io_.write(off);
    if (paced()) std::this_thread::sleep_for(std::chrono::duration<double>(config_.period()));
  }
  if (options_.telemetry) {
    runtime::LoopStatsSample ls;
    ls.stats = report_.stats;
    ls.realtime = paced();
    ls.telemetry_dropped = static_cast<std::int64_t>(options_.telemetry->dropped());
    options_.telemetry->push_loop_stats(ls);
  }
  drain_.reset();  // the last fault events are written
  return report_;
}

}  // namespace dualv::apps
