// `dualv selftest`: the safety layer's commissioning test. Runs the paper program, injects
// one fault per scenario mid-motion and checks the safety layer's answer: the expected
// reaction (SS1 / STO, docs/safety.md), detected within its latency, torque off within its
// time, no torque above safety.torque.max written to the drives, the event in the fault log.
// Prints one table row per scenario; the exit status is 1 when any scenario fails.
//
// Default: against the in-process simulation of the Dual-V (deterministic, simulated time).
// --can IFACE: against drives on a bus. That MOVES THE ROBOT and stops it on purpose, so it
// needs --i-understand-this-moves-hardware. Only faults the host can inject run there
// (requests, controller misbehaviour, feedback faults, deadline misses); drive faults, a lost
// drive and the hardwired e-stop circuit need someone at the machine (see docs/safety.md).
#include <fmt/core.h>

#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "apps/commands.hpp"
#include "apps/config_path.hpp"
#include "apps/experiment/closed_loop.hpp"
#include "apps/experiment/machine.hpp"
#include "apps/experiment/report.hpp"
#include "apps/experiment/robot_config.hpp"
#include "common/yaml_reader.hpp"
#include "control/loop/control_cycle.hpp"
#include "control/loop/periodic_executive.hpp"
#include "control/trajectory/program.hpp"
#include "drivers/canopen_config.hpp"
#include "drivers/canopen_setup.hpp"
#include "safety/fault_injector.hpp"
#include "safety/fault_log.hpp"
#include "sim/plant.hpp"
#include "sim/sim_actuator_set.hpp"

namespace dualv::apps {

namespace {

using safety::Fault;
using safety::Reaction;

// The drives a scenario runs against, and the machine (the one control loop, apps/experiment/
// machine.hpp) over them through a fault injector: a fresh simulation per scenario, or the
// drives on a bus for every scenario (the loop then never stops between scenarios).
class Backend {
 public:
  virtual ~Backend() = default;
  virtual sim::SimActuatorSet* sim() { return nullptr; }
  Machine& machine() { return *machine_; }
  safety::FaultInjector& io() { return *io_; }

 protected:
  void make_machine(const RobotConfig& cfg, drivers::ActuatorSet& drives, Pacing pacing,
                    sim::Plant* plant, bool memory_locked = false, bool start = true) {
    io_ = std::make_unique<safety::FaultInjector>(drives);
    MachineOptions mo;
    mo.pacing = pacing;
    mo.memory_locked = memory_locked;
    mo.on_realtime = [](const control::RealtimeStatus& rt) {
      for (const auto& w : rt.warnings) fmt::print(stderr, "dualv selftest: {}\n", w);
    };
    machine_ = std::make_unique<Machine>(cfg, *io_, mo, plant);
    if (start) machine_->start();
  }
  std::unique_ptr<safety::FaultInjector> io_;
  std::unique_ptr<Machine> machine_;
};

class SimBackend final : public Backend {
 public:
  explicit SimBackend(const RobotConfig& cfg)
      : plant_(cfg.model, cfg.plant), sim_((plant_.reset(cfg.model.home), plant_)) {
    make_machine(cfg, sim_, Pacing::kSimulated, &plant_);
  }
  ~SimBackend() override { machine_.reset(); }
  sim::SimActuatorSet* sim() override { return &sim_; }

 private:
  sim::Plant plant_;
  sim::SimActuatorSet sim_;
};

// The drives on a bus, paced by the clock in this thread: a scenario injects its fault
// between two cycles.
class CanBackend final : public Backend {
 public:
  CanBackend(const RobotConfig& cfg, const std::string& iface) : to_come_(cfg.model.n) {
    const drivers::CanConfig& can = cfg.can;  // read with the rest of the file
    // The slow part of the real-time set-up (mlockall) before the drives boot: their RPDO
    // deadline and heartbeat consumer run from the last priming cycle on.
    control::ExecutiveConfig exec = cfg.loop;
    exec.priority = 0;  // this thread gets SCHED_FIFO when the loop begins
    control::MonotonicClock clock;
    control::PeriodicExecutive early(exec, clock);
    const bool locked = early.prepare_realtime().memory_locked;
    // The machine is set up before the boot, over a stand-in the booted drives fill.
    make_machine(cfg, to_come_, Pacing::kCallerThread, nullptr, locked, false);
    drivers_ = drivers::open_canopen_drives(
        can, {iface, cfg.period(), [](const std::string& s) { fmt::print("  {}\n", s); }});
    to_come_.attach(drivers_->actuators());
    machine_->start();
  }
  ~CanBackend() override {
    machine_.reset();  // the loop ends: drives disabled; then as can.on_exit says
    drivers_->shut_down([](const std::string& s) { fmt::print("  {}\n", s); });
  }
  const drivers::CanopenActuatorSet& canopen() const { return drivers_->actuators(); }

 private:
  DrivesToCome to_come_;
  std::unique_ptr<drivers::CanopenDrives> drivers_;
};

struct Scenario {
  const char* name;
  Reaction expected;
  Fault fault;
  bool sim_only;
  // Injects the fault before cycle `k` (k = 0: the injection cycle); return false to stop
  // injecting. Called every cycle from the injection on.
  std::function<void(class Run&, int k)> inject;
};

struct Outcome {
  std::string observed = "none";
  std::int64_t latency = -1;
  double max_torque = 0.0;
  bool pass = false;
  std::string note;
};

// One scenario: the paper program on the backend's machine, plus injection hooks. On a
// backend that ran a scenario before (the bus), the last stop is reset first and every
// injection and test limit is taken back.
class Run {
 public:
  Run(const RobotConfig& cfg, const trajectory::Program& program, Backend& backend)
      : cfg_(cfg), backend_(backend), loop_(backend.machine().executor()) {
    backend.io().clear();
    loop_.inject_deadline_misses(0);
    loop_.safety().set_limits_for_test(cfg.safety);
    if (loop_.snapshot().mode == control::LoopMode::kSafeStop) reset();
    loop_.cycle().set_command_hook(misbehave_hook, this);
    id_ = backend.machine().begin(program, paper_variants().front(), 0.2);
  }
  ~Run() {
    loop_.cycle().set_command_hook(nullptr, nullptr);
    loop_.inject_deadline_misses(0);
  }
  Run(const Run&) = delete;
  Run& operator=(const Run&) = delete;
  control::CycleStatus step() {
    loop_.inject_deadline_misses(forced_misses_);
    backend_.machine().pump();
    safety::FaultEvent e;
    while (loop_.safety().log().try_pop(e)) events_.push_back(e);
    return rec().status;
  }
  control::Executor& loop() { return loop_; }
  control::ControlCycle& cycle() { return loop_.cycle(); }
  safety::FaultInjector& io() { return backend_.io(); }
  Backend& backend() { return backend_; }
  const control::CycleRecord& rec() const { return loop_.record(); }
  const std::vector<safety::FaultEvent>& events() const { return events_; }
  int forced_misses_ = 0;
  bool hook_nan_ = false;
  bool hook_big_ = false;
  bool hook_step_ = false;
  // A limit test: the configuration's limits with one changed (`change`) from now on.
  void test_limit(const std::function<void(safety::SafetyConfig&)>& change) {
    safety::SafetyConfig c = cycle().safety().config();
    change(c);
    cycle().safety().set_limits_for_test(c);
  }

 private:
  static void misbehave_hook(void* ctx, std::int64_t cycle, drivers::ActuatorCommand& c) noexcept;
  // The previous scenario's stop, reset once its causes are gone (a few cycles for the
  // injections taken back above to show).
  void reset() {
    for (int k = 0; k < 20; ++k) step();
    loop_.submit(control::LoopCommand::Kind::kReset);
    for (int k = 0; k < cfg_.safety.watchdogs.reset_fault_cycles + 200; ++k) {
      step();
      if (loop_.snapshot().mode == control::LoopMode::kIdle) break;
    }
    events_.clear();
  }
  const RobotConfig& cfg_;
  Backend& backend_;
  control::Executor& loop_;
  std::uint64_t id_ = 0;
  std::vector<safety::FaultEvent> events_;
};

void Run::misbehave_hook(void* ctx, std::int64_t, drivers::ActuatorCommand& c) noexcept {
  auto* run = static_cast<Run*>(ctx);
  for (int i = 0; i < c.n; ++i) {
    if (run->hook_big_) c.torque[i] = (i % 2 ? -1.0 : 1.0) * 10.0 * 60.0;  // 10x the default limit
    if (run->hook_nan_ && i == 1) c.torque[i] = std::numeric_limits<double>::quiet_NaN();
  }
  // A step of three times the allowed torque change per cycle on motor 1, well inside the
  // absolute limit: only the rate monitor can see it.
  if (run->hook_step_) c.torque[0] += 3.0 * run->cycle().safety().limits().torque_step;
}

std::vector<Scenario> scenarios(const RobotConfig& cfg) {
  const int stale = cfg.safety.watchdogs.stale_feedback_cycles;
  const int misses = cfg.safety.watchdogs.max_consecutive_deadline_misses;
  (void)stale;
  return {
      {"e-stop request (LCM)", Reaction::kSs1, Fault::kEstopLcm, false,
       [](Run& r, int k) {
         if (k == 0) r.loop().request_estop(safety::StopSource::kLcm);
       }},
      {"e-stop request (signal)", Reaction::kSs1, Fault::kEstopSignal, false,
       [](Run& r, int k) {
         if (k == 0) r.loop().request_estop(safety::StopSource::kSignal);
       }},
      {"e-stop circuit (drive input)", Reaction::kSto, Fault::kEstopInput, true,
       [](Run& r, int k) {
         if (k == 0) r.backend().sim()->set_stop_input(true);
       }},
      {"drive fault (EMCY 2310h)", Reaction::kSto, Fault::kDriveFault, true,
       [](Run& r, int k) {
         if (k == 0) r.backend().sim()->inject_fault(2, 0x2310);
       }},
      {"drive lost (drive 2)", Reaction::kSto, Fault::kDriveLost, true,
       [](Run& r, int k) {
         if (k == 0) r.backend().sim()->set_offline(1, true);
       }},
      {"stale feedback (drive 1)", Reaction::kSto, Fault::kStaleFeedback, false,
       [](Run& r, int k) {
         if (k == 0) r.io().freeze_feedback(0, true);
       }},
      {"encoder jump (drive 4, 0.2 rad)", Reaction::kSto, Fault::kEncoderJump, false,
       [](Run& r, int k) {
         if (k == 0) r.io().jump_encoder(3, 0.2);
       }},
      {"controller 10x torque limit", Reaction::kSs1, Fault::kTorqueLimit, false,
       [](Run& r, int) { r.hook_big_ = true; }},
      {"controller NaN torque", Reaction::kSs1, Fault::kNonFiniteCommand, false,
       [](Run& r, int) { r.hook_nan_ = true; }},
      {"deadline misses", Reaction::kSto, Fault::kDeadlineMisses, false,
       [misses](Run& r, int k) { r.forced_misses_ = std::min(k + 1, misses); }},
      // The rate limit at the lowest value the configuration allows (so the step stays far
      // below the absolute limit whatever the configured rate), then one controller step of
      // three times it.
      {"limit test: torque rate", Reaction::kSs1, Fault::kTorqueRate, false,
       [](Run& r, int k) {
         if (k == 0) r.test_limit([](safety::SafetyConfig& c) { c.torque.max_rate = 100.0; });
         r.hook_step_ = k == 0;
       }},
      // Limit tests, as on a machine being commissioned: one limit at a time is set below
      // what the motion in progress does, and the monitor must trip and stop the robot.
      {"limit test: joint velocity", Reaction::kSs1, Fault::kJointVelocity, false,
       [](Run& r, int k) {
         if (k == 0) r.test_limit([](safety::SafetyConfig& c) { c.max_joint_velocity = 1e-4; });
       }},
      {"limit test: plate velocity", Reaction::kSs1, Fault::kPlateVelocity, false,
       [](Run& r, int k) {
         if (k == 0) r.test_limit([](safety::SafetyConfig& c) { c.max_plate_velocity = 1e-5; });
       }},
      {"limit test: workspace", Reaction::kSs1, Fault::kWorkspace, false,
       [](Run& r, int k) {
         const double x = r.rec().est.X.x();
         if (k == 0)
           r.test_limit([x](safety::SafetyConfig& c) { c.workspace.x = {x + 0.01, x + 0.02}; });
       }},
      {"limit test: singularity distance", Reaction::kSs1, Fault::kSingularity, false,
       [](Run& r, int k) {
         if (k == 0) r.test_limit([](safety::SafetyConfig& c) { c.min_parallel_singularity = 10; });
       }},
      {"limit test: tracking error", Reaction::kSs1, Fault::kTrackingError, false,
       [](Run& r, int k) {
         if (k == 0) r.test_limit([](safety::SafetyConfig& c) { c.max_tracking_error = 1e-7; });
       }},
  };
}

// Allowed detection latency [cycles] from the injection: 2 for limits and requests (the
// issue's requirement), the configured count for the cycle-counted watchdogs.
std::int64_t allowed_latency(const RobotConfig& cfg, Fault f) {
  switch (f) {
    case Fault::kStaleFeedback:
      return cfg.safety.watchdogs.stale_feedback_cycles;
    case Fault::kDeadlineMisses:
      return cfg.safety.watchdogs.max_consecutive_deadline_misses;
    default:
      return 2;
  }
}

Outcome run_scenario(const RobotConfig& cfg, const trajectory::Program& program, Backend& backend,
                     const Scenario& sc, double inject_at, std::vector<safety::FaultEvent>& log) {
  Outcome o;
  Run run(cfg, program, backend);
  // Into the program, moving.
  for (int k = 0; k < 60000; ++k) {
    if (run.step() != control::CycleStatus::kOk ||
        run.loop().mode() != control::LoopMode::kProgram) {
      // The stop's cause: the last stopping fault (warnings may come after it).
      const safety::FaultEvent* stop = nullptr;
      for (const auto& e : run.events())
        if (e.kind == safety::EventKind::kFault && e.reaction != Reaction::kWarn) stop = &e;
      o.note = fmt::format("stopped before the injection: {}",
                           stop                   ? safety::describe(*stop)
                           : run.events().empty() ? "?"
                                                  : safety::describe(run.events().back()));
      log.insert(log.end(), run.events().begin(), run.events().end());
      return o;
    }
    if (run.rec().phase == control::CyclePhase::kRunning && run.rec().t >= inject_at) break;
  }
  const std::int64_t injected = run.rec().cycle + 1;
  const std::int64_t ss1_max = run.cycle().safety().limits().ss1_max;
  std::optional<std::int64_t> detected, off;
  const safety::FaultEvent* event = nullptr;
  for (int k = 0; k < ss1_max + 200; ++k) {
    sc.inject(run, k);
    run.step();
    if (!detected)
      for (const auto& e : run.events())
        if (e.kind == safety::EventKind::kFault && e.reaction != Reaction::kWarn) {
          detected = e.cycle;
          event = &e;
          o.observed = safety::to_string(run.rec().safety.state == safety::SafetyState::kSs1
                                             ? Reaction::kSs1
                                             : Reaction::kSto);
          break;
        }
    if (detected && !off && run.rec().command.request == drivers::DriveRequest::kDisable)
      off = run.rec().cycle;
    if (off && run.rec().cycle > *off + 20) break;
  }
  o.max_torque = run.io().max_torque();
  // The expected cause must be logged within its latency; another cause may come first in
  // the same cycles (an encoder jump on a sample that is not fresh shows first as
  // inconsistent encoders: forward kinematics fails), as long as the reaction is right.
  bool logged = false;
  std::int64_t cause_latency = -1;
  for (const auto& e : run.events())
    if (e.kind == safety::EventKind::kFault && e.fault == sc.fault && !logged) {
      logged = true;
      cause_latency = e.cycle - injected;
    }
  if (detected) o.latency = logged ? cause_latency : *detected - injected;
  const std::int64_t allowed_off = sc.expected == Reaction::kSto ? 0 : ss1_max;
  std::vector<std::string> why;
  if (!detected)
    why.push_back("not detected");
  else if (!logged)
    why.push_back(fmt::format("stopped by: {}", safety::to_string(event->fault)));
  if (detected && o.observed != safety::to_string(sc.expected)) why.push_back("wrong reaction");
  if (detected && (o.latency < 0 || o.latency > allowed_latency(cfg, sc.fault)))
    why.push_back(fmt::format("latency > {}", allowed_latency(cfg, sc.fault)));
  if (!off)
    why.push_back("torque never off");
  else if (detected && *off - *detected > allowed_off)
    why.push_back(fmt::format("torque off after {} cycles", *off - *detected));
  if (o.max_torque > cfg.safety.torque.max) why.push_back("torque above limit");
  if (!logged) why.push_back("not in the fault log");
  o.pass = why.empty();
  for (const auto& w : why) o.note += (o.note.empty() ? "" : "; ") + w;
  if (o.pass && off) o.note = fmt::format("torque off {} cycles after detection", *off - *detected);
  log.insert(log.end(), run.events().begin(), run.events().end());
  // On hardware: wait for the robot to come to rest (disabled) before the next scenario.
  if (!backend.sim())
    for (int k = 0; k < 3000; ++k) {
      run.step();
      double v = 0.0;
      for (int i = 0; i < cfg.model.n; ++i)
        v = std::max(v, std::abs(run.cycle().safety().joint_velocity(i)));
      if (v < cfg.safety.ss1.standstill_velocity) break;
    }
  return o;
}

// The reset rules: refused while the cause is active, accepted once cleared, and no torque
// nor enable afterwards until a new start (sim only: needs the e-stop circuit).
Outcome reset_scenario(const RobotConfig& cfg, const trajectory::Program& program,
                       std::vector<safety::FaultEvent>& log) {
  Outcome o;
  SimBackend backend(cfg);
  Run run(cfg, program, backend);
  for (int k = 0;
       k < 60000 && !(run.rec().phase == control::CyclePhase::kRunning && run.rec().t >= 1.0); ++k)
    run.step();
  backend.sim()->set_stop_input(true);
  for (int k = 0; k < 100; ++k) run.step();
  run.loop().submit(control::LoopCommand::Kind::kReset);
  for (int k = 0; k < cfg.safety.watchdogs.reset_fault_cycles + 2; ++k) run.step();
  auto has = [&](safety::EventKind kind) {
    for (const auto& e : run.events())
      if (e.kind == kind) return true;
    return false;
  };
  const bool refused =
      has(safety::EventKind::kResetRefused) && !has(safety::EventKind::kResetAccepted);
  backend.sim()->set_stop_input(false);
  run.loop().submit(control::LoopCommand::Kind::kReset);
  run.step();
  const bool accepted = has(safety::EventKind::kResetAccepted);
  run.io().reset_max_torque();
  bool quiet = true;
  for (int k = 0; k < 1000; ++k) {
    run.step();
    quiet = quiet && run.rec().command.request == drivers::DriveRequest::kDisable;
  }
  quiet = quiet && run.io().max_torque() == 0.0;
  o.observed = fmt::format("{} / {} / {}", refused ? "refused" : "NOT refused",
                           accepted ? "accepted" : "NOT accepted", quiet ? "disabled" : "MOVED");
  o.latency = 0;
  o.max_torque = run.io().max_torque();
  o.pass = refused && accepted && quiet;
  o.note = "reset with the cause active, then cleared; 1 s without a start";
  log.insert(log.end(), run.events().begin(), run.events().end());
  return o;
}

// A stop caused from outside the host (the e-stop button, a drive fault, a cable pulled,
// another process injecting it): run the program and wait for the safety layer to stop.
Outcome await_external_stop(const RobotConfig& cfg, const trajectory::Program& program,
                            Backend& backend, Reaction expected, double wait_s,
                            std::vector<safety::FaultEvent>& log, std::string& cause) {
  Outcome o;
  Run run(cfg, program, backend);
  const auto cycles = static_cast<std::int64_t>(wait_s / cfg.period());
  std::optional<std::int64_t> detected, off;
  for (std::int64_t k = 0; k < cycles; ++k) {
    run.step();
    if (!detected)
      for (const auto& e : run.events())
        if (e.kind == safety::EventKind::kFault && e.reaction != Reaction::kWarn) {
          detected = e.cycle;
          cause = safety::to_string(e.fault);
          o.observed = safety::to_string(run.rec().safety.state == safety::SafetyState::kSs1
                                             ? Reaction::kSs1
                                             : Reaction::kSto);
          o.latency = e.latency_cycles;
          break;
        }
    if (detected && !off && run.rec().command.request == drivers::DriveRequest::kDisable)
      off = run.rec().cycle;
    if (off && run.rec().cycle > *off + 50) break;
  }
  o.max_torque = run.io().max_torque();
  o.pass = detected && off && o.observed == safety::to_string(expected) &&
           o.max_torque <= cfg.safety.torque.max &&
           (expected == Reaction::kSs1 || *off == *detected);
  o.note = detected ? fmt::format("cause: {}; torque off {} cycles after detection", cause,
                                  off ? *off - *detected : -1)
                    : fmt::format("no stop within {:.1f} s", wait_s);
  log.insert(log.end(), run.events().begin(), run.events().end());
  return o;
}

// A scenario that could not run (e.g. its start refused: a stop latched while idle, after
// the reset before it): the loop's fault events since, into the log, so the stop that refused
// it reaches --fault-log with the rest.
void keep_loop_events(Backend& backend, std::vector<safety::FaultEvent>& log) {
  backend.machine().pump();
  safety::FaultEvent e;
  while (backend.machine().executor().safety().log().try_pop(e)) log.push_back(e);
}

struct SelftestArgs {
  std::string config;
  std::string program;
  std::string can;
  bool confirmed = false;
  std::string fault_log;
  double inject_at = 2.0;  // mid-shape: the plate is moving
  std::vector<std::string> only;
  double await_stop = 0.0;
  std::string expect = "sto";
};

int selftest(const SelftestArgs& args) {
  const RobotConfig cfg = load_robot_config(resolve_config(args.config));
  const std::string program_file = resolve_program(args.program);
  trajectory::ProgramContext ctx;
  ctx.start = ctx.home = cfg.model.home;
  ctx.workspace = cfg.trajectory.limits.workspace;
  const trajectory::Program program = trajectory::load_program_file(program_file, ctx);

  std::unique_ptr<Backend> can;
  if (!args.can.empty()) {
    fmt::print(stderr,
               "\n  WARNING: dualv selftest --can {} runs against real drives.\n"
               "  It MOVES THE ROBOT (the paper program) and stops it on purpose, once per\n"
               "  scenario. Keep the workspace clear and the hardwired e-stop within reach.\n"
               "  The software stop tested here is NOT a certified safety function.\n\n",
               args.can);
    if (!args.confirmed) {
      fmt::print(stderr,
                 "dualv selftest: refused: add --i-understand-this-moves-hardware to go on\n");
      return 2;
    }
    can = std::make_unique<CanBackend>(cfg, args.can);
  }
  fmt::print(
      "dualv selftest: {} scenarios against {} at {:.0f} Hz, fault injected at t = {:.2f} s "
      "of {}\n\n",
      can ? "host-injectable" : "all",
      can ? "the drives on " + args.can : "the in-process simulation", cfg.rate_hz(),
      args.inject_at, program_file);
  fmt::print("{:<34} {:<9} {:<9} {:>9} {:>11}  {:<5} {}\n", "scenario", "expected", "observed",
             "latency", "max torque", "pass", "note");
  fmt::print("{:<34} {:<9} {:<9} {:>9} {:>11}  {:<5}\n", "", "", "", "[cycles]", "[N m]", "");
  std::vector<safety::FaultEvent> log;
  int failed = 0, ran = 0;
  auto row = [&](const std::string& name, const std::string& expected, const Outcome& o) {
    fmt::print("{:<34} {:<9} {:<9} {:>9} {:>11.2f}  {:<5} {}\n", name, expected, o.observed,
               o.latency < 0 ? std::string("-") : std::to_string(o.latency), o.max_torque,
               o.pass ? "PASS" : "FAIL", o.note);
    ++ran;
    if (!o.pass) ++failed;
  };
  auto selected = [&](const std::string& name) {
    if (args.only.empty()) return true;
    for (const auto& s : args.only)
      if (name.find(s) != std::string::npos) return true;
    return false;
  };
  if (args.await_stop > 0.0) {
    // Only the external stop: e.g. the operator presses the e-stop, or (HIL tests) the
    // drive emulator injects a fault.
    std::unique_ptr<SimBackend> sim;
    if (!can) sim = std::make_unique<SimBackend>(cfg);
    const Reaction expected = args.expect == "ss1" ? Reaction::kSs1 : Reaction::kSto;
    fmt::print(stderr,
               "dualv selftest: waiting up to {:.1f} s for a stop from outside (e.g. press "
               "the e-stop)\n",
               args.await_stop);
    std::string cause;
    Backend& backend = can ? *can : *sim;
    Outcome o;
    try {
      o = await_external_stop(cfg, program, backend, expected, args.await_stop, log, cause);
    } catch (const std::exception& e) {
      o.note = e.what();
      keep_loop_events(backend, log);
    }
    row("external stop", safety::to_string(expected), o);
  }
  for (const Scenario& sc : scenarios(cfg)) {
    if (args.await_stop > 0.0 && args.only.empty()) break;
    if (!selected(sc.name)) continue;
    if (can && sc.sim_only) {
      fmt::print("{:<34} {:<9} {:<9} {:>9} {:>11}  {:<5} {}\n", sc.name,
                 safety::to_string(sc.expected), "-", "-", "-", "SKIP",
                 "needs someone at the machine (docs/safety.md)");
      continue;
    }
    std::unique_ptr<SimBackend> sim;
    if (!can) sim = std::make_unique<SimBackend>(cfg);
    Backend& backend = can ? *can : *sim;
    Outcome o;
    try {
      o = run_scenario(cfg, program, backend, sc, args.inject_at, log);
    } catch (const std::exception& e) {
      o.note = e.what();
      keep_loop_events(backend, log);
    }
    row(sc.name, safety::to_string(sc.expected), o);
  }
  if (!can && args.await_stop <= 0.0 && selected("reset"))
    row("reset: causes cleared, no restart", "refuse/ok", reset_scenario(cfg, program, log));
  if (!args.fault_log.empty()) {
    safety::FaultLog ring;
    safety::FaultLogWriter writer(args.fault_log);
    for (const auto& e : log) {
      ring.record(e);
      writer.drain(ring);
    }
    fmt::print("\nfault log: {} events in {}\n", log.size(), args.fault_log);
  }
  if (auto* bus = dynamic_cast<CanBackend*>(can.get())) {
    // What the master counted on the bus (the HIL tests check a frame fault was counted).
    fmt::print("\n{}", bus_report(bus->canopen()));
  }
  fmt::print("\n{} of {} scenarios passed{}\n", ran - failed, ran, failed ? ": FAILED" : "");
  return failed ? 1 : 0;
}

}  // namespace

void register_selftest_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "selftest", "Commissioning test of the safety layer: inject each fault, check the reaction");
  static SelftestArgs args;
  add_config_option(*cmd, args.config);
  cmd->add_option("-p,--program", args.program, program_help());
  cmd->add_option("--can", args.can,
                  "Run against the drives on this SocketCAN interface (moves hardware)");
  cmd->add_flag("--i-understand-this-moves-hardware", args.confirmed,
                "Confirm that --can may move the real robot");
  cmd->add_option("--fault-log", args.fault_log,
                  "Write every safety event as JSON lines to this file");
  cmd->add_option("--inject-at", args.inject_at, "Program time of the injection [s]")
      ->check(CLI::Range(0.0, 60.0))
      ->capture_default_str();
  cmd->add_option("--only", args.only, "Run only scenarios whose name contains one of these");
  cmd->add_option("--await-stop", args.await_stop,
                  "Instead: run the program and wait this long [s] for a stop caused outside the "
                  "host (press the e-stop, pull a cable); pass when it stops as --expect says")
      ->check(CLI::Range(0.0, 3600.0));
  cmd->add_option("--expect", args.expect, "Reaction --await-stop expects: sto or ss1")
      ->check(CLI::IsMember({"sto", "ss1"}))
      ->capture_default_str();
  cmd->callback([] {
    install_stop_signal_handlers();  // SIGINT: an e-stop request of the running loop
    exit_code() = selftest(args);
  });
}

}  // namespace dualv::apps
