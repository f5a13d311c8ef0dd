// `dualv run`: the paper's experiment in closed loop (default: the in-process simulation).
#include <fmt/core.h>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "apps/commands.hpp"
#include "apps/config_path.hpp"
#include "apps/experiment/closed_loop.hpp"
#include "apps/experiment/machine.hpp"
#include "apps/experiment/report.hpp"
#include "apps/experiment/robot_config.hpp"
#include "common/yaml_reader.hpp"
#include "control/loop/cycle_stats.hpp"
#include "control/model/kinematics.hpp"
#include "control/trajectory/preflight.hpp"
#include "control/trajectory/program.hpp"
#include "drivers/canopen_actuator_set.hpp"
#include "drivers/canopen_setup.hpp"
#include "runtime/channels.hpp"
#include "runtime/command_auth.hpp"
#include "runtime/command_channel.hpp"
#include "runtime/lcm_url.hpp"
#include "runtime/replay_state.hpp"
#include "runtime/service_notifier.hpp"
#include "runtime/telemetry_publisher.hpp"
#include "safety/fault_log.hpp"
#include "sim/plant.hpp"
#include "sim/sim_actuator_set.hpp"

namespace dualv::apps {

namespace {

struct RunArgs {
  std::string config;
  std::string program;
  std::string out;
  double rate_hz = 0.0;
  std::vector<std::string> variants;
  bool plots = true;
  bool realtime = false;
  std::string can;
  bool move_hardware = false;
  std::string lcm;
  std::string commands;
  std::string keys;
  std::string replay_state;
  bool serve = false;
};

// The program name of `dualv start` that starts a streaming run instead of a program file.
constexpr const char* kStreamProgram = "stream";

// `dualv run --serve`: the service. The machine's loop runs from boot to shutdown (idle:
// drives disabled at 0 N m, telemetry at 50 Hz); signed `dualv start PROGRAM --key K` commands
// are prepared here (loaded, pre-flighted, rebased on the pose the loop reports) and handed to
// the loop, which takes them at a cycle boundary; `dualv start stream` follows signed setpoints
// (`dualv stream`) until a signed stop or until the stream goes silent (SS1). The loop refuses a
// start while a stop is latched (after any safety stop, or an e-stop while idle, even one that
// came while the program was being prepared): a signed reset clears it, and a reset never starts
// motion. Ends on SIGINT/SIGTERM: at once while idle, after the controlled stop (SS1) of a
// program in progress.
//
// systemd hears the state as STATUS= lines; every cycle of the loop is the watchdog's proof of
// life (ServiceNotifier::beat in the loop's hooks), so a hung loop gets the service killed.
int serve(const RobotConfig& cfg, Machine& machine, runtime::CommandChannel& commands,
          runtime::ServiceNotifier& service) {
  control::Executor& loop = machine.executor();
  fmt::print("dualv run: serving: waiting for `dualv start PROGRAM` (Ctrl-C to end)\n");
  service.ready("waiting for start");
  // What the loop follows now, for its messages: file name and start key.
  struct Current {
    std::uint64_t id = 0;
    std::string name;  // "stream" or the program file
  } current;
  std::uint64_t estops = commands.estop_requests();
  auto end_of = [&](const control::LoopEvent& e, bool ok) {
    if (e.id == 0 || e.id != current.id) return;
    const std::string what = current.name == kStreamProgram ? std::string("stream") : current.name;
    const std::string failure =
        ok ? std::string()
           : fmt::format("cycle {} (t = {:.3f} s): {}{}", e.cycle, e.t,
                         control::to_string(e.status),
                         e.latched ? " (" + safety::describe_faults(e.latched) + ")" : "");
    std::string counts;
    if (current.name == kStreamProgram) {
      const control::LoopSnapshot snap = loop.snapshot();
      counts =
          fmt::format("; setpoints: {} followed, {} refused by the loop, {} refused on receipt",
                      snap.stream_accepted, snap.stream_refused, commands.setpoints_refused());
    }
    fmt::print("dualv run: {} {}{}{}\n", what, ok ? "done" : "STOPPED", ok ? "" : ": " + failure,
               counts);
    const std::string name = std::filesystem::path(what).filename().string();
    service.status(ok ? fmt::format("waiting for start (last: {} done)", name)
                      : fmt::format("stopped: {}: {}; waiting for a signed reset", name, failure));
    current = {};
  };
  for (;;) {
    machine.pump();
    // A signal ends the service once nothing runs: a program in progress is stopped (SS1,
    // latched by the signal itself) and reported first.
    if (stop_signal_received() && current.id == 0) {
      fmt::print("dualv run: stop signal: ending the service\n");
      service.stopping("stopping: signal received");
      return 0;
    }
    if (commands.estop_requests() != estops) {
      estops = commands.estop_requests();
      if (current.id == 0) {
        service.status("stopped: e-stop while idle; waiting for a signed reset");
        fmt::print("dualv run: e-stop received while idle: a reset is needed before a start\n");
      }
    }
    control::LoopEvent e;
    while (loop.poll_event(e)) {
      using K = control::LoopEvent::Kind;
      if (e.kind == K::kFinished) end_of(e, true);
      if (e.kind == K::kStopped && e.id == 0) {  // nothing was followed: say why it stopped
        const std::string why = e.latched ? safety::describe_faults(e.latched)
                                          : std::string(control::to_string(e.status));
        fmt::print("dualv run: stopped while idle (cycle {}): {}\n", e.cycle, why);
        service.status(fmt::format("stopped while idle: {}; waiting for a signed reset", why));
      }
      if (e.kind == K::kStopped) end_of(e, false);
      if (e.kind == K::kRefused && e.id == current.id) {
        fmt::print(stderr, "dualv run: start of '{}' refused: {}\n", current.name,
                   e.reason == control::RefuseReason::kLatched
                       ? std::string("the last stop has not been reset")
                       : control::to_string(e.reason));
        current = {};
      }
      if (e.kind == K::kTorqueOff)
        fmt::print("dualv run: torque off (STO){}; a signed reset is needed before a start\n",
                   e.latched ? ": " + safety::describe_faults(e.latched) : std::string());
      if (e.kind == K::kReset) {
        fmt::print(
            "dualv run: reset accepted: drives disabled, a start command is accepted again\n");
        service.status("waiting for start");
      }
      if (e.kind == K::kResetRefused)
        fmt::print(stderr, "dualv run: reset refused: still active: {}\n",
                   safety::describe_faults(e.latched));
    }
    runtime::VerifiedCommand cmd;
    if (!commands.try_pop(cmd)) continue;  // the pump above waited (paced) or ran a cycle
    if (cmd.kind == runtime::CommandKind::kReset) {
      loop.submit(control::LoopCommand::Kind::kReset);
      fmt::print("dualv run: reset (key {}) requested\n", cmd.key_id);
      continue;
    }
    if (cmd.kind == runtime::CommandKind::kStop) {
      loop.submit(control::LoopCommand::Kind::kStop);
      continue;
    }
    if (cmd.kind != runtime::CommandKind::kStartProgram || stop_signal_received()) continue;
    // The e-stop count when the start came: one that comes while it is prepared refuses it.
    const std::uint64_t epoch = loop.estop_epoch();
    const control::LoopSnapshot snap = loop.snapshot();
    if (snap.latched != 0 || snap.mode == control::LoopMode::kSafeStop) {
      fmt::print(stderr, "dualv run: start of '{}' refused: the last stop has not been reset\n",
                 cmd.program);
      continue;
    }
    if (current.id != 0) {
      fmt::print(stderr, "dualv run: start of '{}' refused: {} is running\n", cmd.program,
                 current.name);
      continue;
    }
    try {
      std::unique_ptr<control::PreparedReference> ref;
      std::string name = cmd.program;
      if (name == kStreamProgram) {
        fmt::print("dualv run: starting stream (key {}): following signed setpoints on {}\n",
                   cmd.key_id, runtime::kSetpointChannel);
        ref = loop.prepare_stream(cfg.trajectory.streaming, cfg.trajectory.limits.workspace, epoch);
        service.status(fmt::format("streaming (key {})", cmd.key_id));
      } else {
        const std::string file = resolve_named_program(cmd.program);
        trajectory::ProgramContext ctx;
        ctx.start = ctx.home = cfg.model.home;
        ctx.workspace = cfg.trajectory.limits.workspace;
        const trajectory::Program program = trajectory::load_program_file(file, ctx);
        const trajectory::Program timed =
            trajectory::with_timing(program, paper_variants().front().timing);
        trajectory::preflight_or_throw(cfg.model, timed, cfg.trajectory.limits);
        if (stop_signal_received()) continue;  // ending: start nothing new
        ref = loop.prepare_program(timed, cfg.trajectory.rebase, epoch);
        name = file;
        fmt::print("dualv run: starting {} (key {})\n", file, cmd.key_id);
        service.status(fmt::format("running {} (key {})",
                                   std::filesystem::path(file).filename().string(), cmd.key_id));
      }
      ref->name = name;
      current.name = name;
      current.id = loop.start(std::move(ref));
      if (current.id == 0) throw std::runtime_error("the control loop's command queue is full");
    } catch (const std::exception& error) {
      fmt::print(stderr, "dualv run: start of '{}' refused: {}\n", cmd.program, error.what());
      current = {};
    }
  }
}

// What a streamed setpoint must satisfy beyond its signature, checked on receipt (and logged
// there when refused): inside trajectory.limits.workspace (the loop checks that again), a pose
// the model reaches, away from singularities by the pre-flight margins.
runtime::CommandChannel::SetpointCheck setpoint_check(const RobotConfig& cfg) {
  auto data = std::make_shared<model::Data>(cfg.model);
  return [&cfg, data](double x, double y, double theta) -> std::string {
    const trajectory::Limits& l = cfg.trajectory.limits;
    if (!l.workspace.x.contains(x) || !l.workspace.y.contains(y) ||
        !l.workspace.theta.contains(theta))
      return fmt::format("({:.4f}, {:.4f}, {:.4f}) is outside trajectory.limits.workspace", x, y,
                         theta);
    const model::Pose X(x, y, theta);
    const model::Status st = model::update_kinematics(cfg.model, *data, X, model::Twist::Zero());
    if (st != model::Status::kOk)
      return fmt::format("({:.4f}, {:.4f}, {:.4f}): {}", x, y, theta, model::to_string(st));
    const model::SingularityMeasures m = model::singularity_measures(cfg.model, *data);
    if (m.parallel < l.min_parallel_singularity || m.min_serial < l.min_serial_singularity)
      return fmt::format("({:.4f}, {:.4f}, {:.4f}) is too close to a singularity", x, y, theta);
    return {};
  };
}

std::string default_out_dir() {
  const std::time_t now = std::time(nullptr);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::localtime(&now));
  return std::string("out/run-") + stamp;
}

int run(const RunArgs& args) {
  // systemd's Type=notify protocol (does nothing outside systemd): READY=1 once set-up is done.
  runtime::ServiceNotifier service;
  RobotConfig cfg = load_robot_config(resolve_config(args.config));
  // --rate: the rate-dependent checks again (SYNC, filter, safety times, bus load on CAN).
  if (args.rate_hz > 0.0) override_rate(cfg, args.rate_hz, !args.can.empty());
  const std::string program_file = resolve_program(args.program);
  trajectory::ProgramContext ctx;
  ctx.start = cfg.model.home;
  ctx.home = cfg.model.home;
  ctx.workspace = cfg.trajectory.limits.workspace;
  const trajectory::Program program = trajectory::load_program_file(program_file, ctx);

  std::vector<Variant> variants;
  for (const auto& v : paper_variants())
    if (args.variants.empty() ||
        std::find(args.variants.begin(), args.variants.end(), v.name) != args.variants.end())
      variants.push_back(v);
  for (const auto& name : args.variants) {
    const auto all = paper_variants();
    if (std::none_of(all.begin(), all.end(), [&](const Variant& v) { return v.name == name; })) {
      std::string known;
      for (const auto& v : all) known += " " + v.name;
      fmt::print(stderr, "dualv run: unknown variant '{}' (known:{})\n", name, known);
      return 2;
    }
  }

  // Pre-flight every variant before anything moves.
  for (const auto& v : variants)
    trajectory::preflight_or_throw(cfg.model, trajectory::with_timing(program, v.timing),
                                   cfg.trajectory.limits);

  // Real drives move a 127 N m machine: a virtual bus is fine, anything else needs consent.
  if (!args.can.empty() && args.can.rfind("vcan", 0) != 0 && !args.move_hardware) {
    fmt::print(stderr,
               "dualv run: --can {} is not a virtual CAN interface: this will move the robot.\n"
               "Check the workspace is clear and the hardwired e-stop is in reach, then add "
               "--yes-move-hardware.\n",
               args.can);
    return 2;
  }
  // The drives' clock: each cycle's reads and writes take the loop's wake-up as their time (no
  // clock read of their own: drivers/canopen/cycle_clock.hpp); declared first, it outlives them.
  drivers::canopen::SteadyClock steady_clock;
  drivers::canopen::CycleClock cycle_clock(steady_clock);
  std::unique_ptr<drivers::CanopenDrives> drives;
  // A paced loop's real-time thread is set up before the drives boot (mlockall and the rest
  // take a while), so their first cycle follows the priming at once.
  const bool paced = args.realtime || !args.can.empty() || args.serve;
  control::MonotonicClock mono;
  std::unique_ptr<control::LoopThread> loop_thread;
  if (paced && args.serve) {
    control::ExecutiveConfig exec = cfg.loop;
    exec.realtime = true;
    loop_thread = std::make_unique<control::LoopThread>(exec, mono, &mono);
    for (const auto& w : loop_thread->launch().warnings) fmt::print(stderr, "dualv run: {}\n", w);
  }
  bool memory_locked = false;
  if (paced && !args.serve) {  // the loop runs in this thread: lock memory before the boot
    control::ExecutiveConfig exec = cfg.loop;
    exec.realtime = true;
    exec.priority = 0;  // SCHED_FIFO when the loop begins, not for the set-up
    control::PeriodicExecutive early(exec, mono);
    const control::RealtimeStatus& rt = early.prepare_realtime();
    memory_locked = rt.memory_locked;
    for (const auto& w : rt.warnings) fmt::print(stderr, "dualv run: {}\n", w);
  }
  const std::string out = args.out.empty() ? default_out_dir() : args.out;
  std::filesystem::create_directories(out);
  fmt::print("dualv run: {} ({} segments, {:.2f} s) on {} at {:.0f} Hz{}\n", program_file,
             program.size(), program.duration(),
             !args.can.empty() ? "the CANopen drives on " + args.can
                               : std::string("the in-process simulated Dual-V"),
             cfg.rate_hz(), paced ? ", paced in real time" : ", simulated time");
  // Telemetry: an LCM log in the output folder (LCM's file provider: no network), or live.
  const std::string log_file = out + "/telemetry.lcmlog";
  runtime::TelemetryPublisher telemetry(args.lcm.empty() ? runtime::log_url(log_file) : args.lcm);
  telemetry.start();
  // Operator commands: e-stop from anyone, stop/reset signed with a key from the key folder.
  std::unique_ptr<runtime::CommandChannel> commands;
  // Commands on their own port (runtime/lcm_url.hpp): never queued behind the telemetry.
  const std::string command_url = !args.commands.empty() ? args.commands
                                  : args.lcm.empty()     ? std::string()
                                                         : runtime::command_url(args.lcm);
  if (!command_url.empty()) {
    const std::string key_dir = resolve_keys_dir(args.keys);
    std::vector<runtime::CommandKey> keys;
    if (std::filesystem::is_directory(key_dir)) {
      std::vector<std::string> warnings;
      keys = runtime::load_command_keys(key_dir, &warnings);
      for (const auto& w : warnings) fmt::print(stderr, "dualv run: {}\n", w);
    }
    // Signed commands are refused as replays across restarts too (issue 14, defect 5).
    runtime::CommandAuthConfig auth;
    auth.replay_state_file = resolve_replay_state(args.replay_state);
    const std::string first_use = runtime::create_replay_state_on_first_use(auth.replay_state_file);
    if (!first_use.empty()) fmt::print("dualv run: {}\n", first_use);
    fmt::print(
        "dualv run: listening for operator commands on {} ({} key(s) from {}; e-stop needs "
        "none; replay state {})\n",
        command_url, keys.size(), key_dir, auth.replay_state_file);
    commands = std::make_unique<runtime::CommandChannel>(
        command_url, runtime::CommandVerifier(std::move(keys), auth));
    commands->set_setpoint_check(setpoint_check(cfg));
    commands->start();
  }
  if (args.serve && !commands) {
    fmt::print(stderr, "dualv run: --serve needs --commands URL (or --lcm URL)\n");
    return 2;
  }
  // Ctrl-C: a controlled stop (SS1), not a dropped robot; the idle service ends cleanly.
  install_stop_signal_handlers(args.serve);

  // The machine: the in-process simulation or the drives, and the one loop that owns them.
  std::unique_ptr<sim::Plant> plant;
  std::unique_ptr<sim::SimActuatorSet> sim_io;
  if (args.can.empty()) {
    plant = std::make_unique<sim::Plant>(cfg.model, cfg.plant);
    plant->reset(cfg.model.home);
    sim_io = std::make_unique<sim::SimActuatorSet>(*plant);
  }
  MachineOptions mo;
  // The service's loop has a thread of its own (its supervisor prepares programs while the
  // loop runs); a one-shot run paces the loop in this thread, a cycle per pump, with the
  // supervisor's bookkeeping between two cycles (no second thread competing for the CPU).
  mo.pacing = !paced       ? Pacing::kSimulated
              : args.serve ? Pacing::kLoopThread
                           : Pacing::kCallerThread;
  mo.memory_locked = memory_locked;
  if (!args.can.empty()) mo.cycle_clock = &cycle_clock;  // paced on `mono`: CLOCK_MONOTONIC
  mo.telemetry = &telemetry;
  mo.commands = commands.get();
  mo.service = &service;
  mo.fault_log_path = out + "/faults.jsonl";
  // The machine is made before the drives boot (its set-up allocates, and under mlockall
  // every new page costs), over a stand-in that the booted drives then fill.
  DrivesToCome to_come(cfg.model.n);
  Machine machine(cfg, args.can.empty() ? static_cast<drivers::ActuatorSet&>(*sim_io) : to_come, mo,
                  plant.get(), std::move(loop_thread));
  // The drives boot last, right before their loop starts: their RPDO deadline and heartbeat
  // consumer run from the last priming cycle on.
  std::uint64_t rpdo_deadline_ns = 0;
  std::int64_t primed_ns = 0;
  if (!args.can.empty()) {
    if (args.variants.empty()) {  // on drives, the proposed method only unless asked
      variants.clear();
      variants.push_back(paper_variants().front());
    }
    const drivers::CanConfig& can = cfg.can;  // read with the rest of the file (--rate included)
    rpdo_deadline_ns = can.rpdo_deadline_ns;
    drivers::CanopenSetupOptions opts;
    opts.interface = args.can;
    opts.control_period_s = cfg.period();
    opts.log = [](const std::string& line) { fmt::print("  {}\n", line); };
    opts.clock = &cycle_clock;
    fmt::print("dualv run: booting the drives on {}\n", args.can);
    drives = drivers::open_canopen_drives(can, opts);
    to_come.attach(drives->actuators());
    primed_ns = mono.now_ns();
  }

  // Frames sent before the loop (boot, priming): the bus report below separates them.
  const std::uint64_t syncs_before = drives ? drives->actuators().counters().sync_sent : 0;
  machine.start();
  if (drives) {
    // The drives' RPDO deadline ran from the last priming cycle to the loop's first.
    const double gap_ms = static_cast<double>(machine.first_cycle_ns() - primed_ns) * 1e-6;
    if (rpdo_deadline_ns > 0 && gap_ms > static_cast<double>(rpdo_deadline_ns) * 1e-6)
      fmt::print(stderr,
                 "dualv run: WARNING: the control loop's first cycle came {:.1f} ms after the "
                 "drives were primed, past their RPDO deadline (can.rpdo_deadline {:.0f} ms): "
                 "they may report EMCY 8250h; the drives stay disabled until a start, and a "
                 "signed reset clears the fault\n",
                 gap_ms, static_cast<double>(rpdo_deadline_ns) * 1e-6);
    else
      fmt::print("dualv run: control loop running {:.1f} ms after the drives were primed\n",
                 gap_ms);
  }
  const auto leave_log = [](const std::string& line) { fmt::print("  {}\n", line); };
  if (args.serve) {
    const int rc = serve(cfg, machine, *commands, service);
    const control::RunReport loop_report = machine.shutdown();
    cycle_clock.end_cycle();  // the loop has ended: real time again for the shut-down
    if (drives) drives->shut_down(leave_log);  // disabled, then as can.on_exit says
    // How the loop kept its time over the service's life, idle included, and what crossed the
    // bus as the master counted it (frames the kernel refused included: ENOBUFS).
    fmt::print("\n{}", control::format_loop_stats(loop_report.stats));
    if (drives)
      fmt::print("\n{}", bus_report(drives->actuators(), static_cast<std::int64_t>(syncs_before)));
    return rc;
  }

  std::vector<RunResult> runs;
  const std::string program_name = std::filesystem::path(program_file).filename().string();
  service.ready(fmt::format("starting {}", program_name));
  // A terminal gets one line rewritten in place; a log gets a line per second of robot time.
  const bool tty = isatty(fileno(stdout));
  for (const auto& v : variants) {
    if (stop_signal_received()) break;  // stopped by a signal: no further variant starts
    if (!runs.empty() && !runs.back().ok) {
      fmt::print("  {:<24} not started: the last variant stopped (a reset is needed)\n", v.name);
      continue;
    }
    service.status(fmt::format("running {} ({})", program_name, v.name));
    RunOptions opts;
    opts.commands = commands.get();
    opts.progress = [tty](const std::string& name, double t, double duration) {
      if (tty) {
        fmt::print("\r  {:<24} t = {:5.2f} / {:.2f} s", name, t, duration);
        std::fflush(stdout);
      } else if (std::fmod(t + 1e-9, 1.0) < 0.5) {
        fmt::print("  {:<24} t = {:5.2f} / {:.2f} s\n", name, t, duration);
      }
    };
    try {
      runs.push_back(machine.run(program, v, opts));
    } catch (const std::exception& e) {
      RunResult r;
      r.variant = v;
      r.n = cfg.model.n;
      r.ok = false;
      r.failure = e.what();
      runs.push_back(r);
    }
    const RunResult& r = runs.back();
    fmt::print("{}  {:<24} {} in {:.2f} s wall ({:.0f}x real time){}\n", tty ? "\r" : "", v.name,
               r.ok ? "done" : "FAILED", r.wall_time, r.robot_time / std::max(r.wall_time, 1e-9),
               r.ok ? "" : ": " + r.failure);
  }
  const control::RunReport loop_report = machine.shutdown();
  cycle_clock.end_cycle();
  if (drives) drives->shut_down(leave_log);  // disabled, then as can.on_exit says
  for (auto& r : runs) r.loop = loop_report.stats;
  // The loop is over: systemd stops watching while the results are written.
  std::string ending;
  for (const auto& r : runs)
    if (!r.ok && ending.empty()) ending = "stopped: " + r.variant.name + ": " + r.failure;
  service.stopping(!ending.empty() ? ending
                   : stop_signal_received()
                       ? std::string("stopped: signal received")
                       : fmt::format("finished {}: {} run(s) done", program_name, runs.size()));
  telemetry.stop();
  const runtime::TelemetryCounters tc = telemetry.counters();
  fmt::print("\n{}", summary_table(runs));
  if (paced && !runs.empty()) fmt::print("\n{}", control::format_loop_stats(loop_report.stats));
  if (drives) {
    // What crossed the bus, as the master counted it (the HIL tests compare it with candump).
    fmt::print("\n{}", bus_report(drives->actuators(), static_cast<std::int64_t>(syncs_before)));
  }
  write_csv(out, runs);
  if (args.plots) {
    const std::string why = draw_plots(out);
    if (!why.empty()) fmt::print(stderr, "dualv run: no plots: {}\n", why);
  }
  fmt::print("\ntelemetry: {} robot states{} {}\n", tc.states,
             tc.states_dropped
                 ? fmt::format(" ({} dropped: the publisher fell behind)", tc.states_dropped)
                 : "",
             args.lcm.empty() ? "in " + log_file + " (lcm-logplayer, dualv status --lcm file://...)"
                              : "published on " + args.lcm);
  fmt::print("results in {}/ (CSV time series, summary.csv{})\n", out,
             args.plots ? ", PNG figures" : "");
  for (const auto& r : runs)
    if (!r.ok) return 1;
  return 0;
}

}  // namespace

void register_run_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("run",
                                 "Run a program in closed loop (default: the paper's experiment "
                                 "on the in-process simulation)");
  static RunArgs args;
  add_config_option(*cmd, args.config);
  cmd->add_option("-p,--program", args.program, program_help());
  cmd->add_option("-o,--out", args.out, "Output folder (default: out/run-<date>-<time>)");
  cmd->add_option("--rate", args.rate_hz,
                  "Control rate [Hz] (default: loop.rate_hz); the SYNC period follows, and the "
                  "checks that depend on the rate run again (velocity filter below Nyquist, "
                  "plant rate, safety times of at least a cycle, can: deadlines, bus load on "
                  "--can)")
      ->check(CLI::Range(10.0, 20000.0));
  cmd->add_option("--variant", args.variants,
                  "Run only these variants: retimed, original, retimed-no-projection, "
                  "retimed-no-feedforward (default: all)");
  cmd->add_flag("!--no-plots", args.plots, "Skip the PNG figures");
  cmd->add_flag(
      "--realtime", args.realtime,
      "Pace the in-process simulation by the clock at the control rate and report jitter");
  cmd->add_option(
      "--can", args.can,
      "Control CANopen drives (or `dualv sim --can IFACE`) on this SocketCAN interface");
  cmd->add_option("--lcm", args.lcm,
                  "Publish telemetry live on this LCM URL (e.g. udpm://239.255.76.67:7667?ttl=0) "
                  "instead of writing <out>/telemetry.lcmlog");
  cmd->add_option("--commands", args.commands,
                  "Receive operator commands (dualv estop/start/reset/stream) on this LCM URL "
                  "(default with --lcm: its multicast group one port up, where those commands "
                  "send when given the same --lcm)");
  cmd->add_flag("--serve", args.serve,
                "Wait for signed `dualv start PROGRAM` commands and run them (the service mode); "
                "`dualv start stream` follows signed setpoints from `dualv stream` until a signed "
                "stop, or stops (SS1) when they cease for safety.watchdogs.command_stream_timeout");
  cmd->add_option("--keys", args.keys, keys_help());
  cmd->add_option("--replay-state", args.replay_state, replay_state_help());
  cmd->add_flag("--yes-move-hardware", args.move_hardware,
                "Confirm that --can on a real (non-vcan) interface may move the robot");
  cmd->callback([] { exit_code() = run(args); });
}

}  // namespace dualv::apps
