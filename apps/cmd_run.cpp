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
#include "runtime/service_notifier.hpp"
#include "runtime/telemetry_publisher.hpp"

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
  bool serve = false;
};

// The program name of `dualv start` that starts a streaming run instead of a program file.
constexpr const char* kStreamProgram = "stream";

// `dualv run --serve`: waits for signed start commands (`dualv start PROGRAM --key K`) and runs
// each program (the proposed method) in turn; `dualv start stream` runs a stream of signed
// setpoints (`dualv stream`) until a signed stop or until the stream goes silent (SS1). After a
// run that ended in a safety stop, or an e-stop while idle, a start is refused until a signed
// reset: a reset never starts motion and nothing moves again without both. Ends on
// SIGINT/SIGTERM: at once while idle, after the controlled stop (SS1) of a run in progress.
// `run_one(nullptr)` runs a stream.
//
// systemd hears the state as STATUS= lines; while idle this loop is the watchdog's proof of
// life (one beat per poll), while a program runs the control loop is (one beat per cycle).
int serve(const RobotConfig& cfg, runtime::CommandChannel& commands,
          runtime::ServiceNotifier& service,
          const std::function<RunResult(const trajectory::Program*)>& run_one) {
  bool need_reset = false;
  std::uint64_t estops = commands.estop_requests();
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // a service's log: one line at a time
  fmt::print("dualv run: serving: waiting for `dualv start PROGRAM` (Ctrl-C to end)\n");
  std::fflush(stdout);
  service.ready("waiting for start");
  for (;;) {
    service.beat();
    if (stop_signal_received()) {
      fmt::print("dualv run: stop signal: ending the service\n");
      service.stopping("stopping: signal received");
      return 0;
    }
    if (commands.estop_requests() != estops) {
      estops = commands.estop_requests();
      if (!need_reset) service.status("stopped: e-stop while idle; waiting for a signed reset");
      need_reset = true;
      fmt::print("dualv run: e-stop received while idle: a reset is needed before a start\n");
    }
    // Setpoints while no stream runs move nothing: drop them, so a stream starts from fresh ones.
    runtime::VerifiedSetpoint stale;
    while (commands.try_pop_setpoint(stale)) {
    }
    runtime::VerifiedCommand cmd;
    if (!commands.try_pop(cmd)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    if (cmd.kind == runtime::CommandKind::kReset) {
      need_reset = false;
      fmt::print("dualv run: reset (key {}): a start command is accepted again\n", cmd.key_id);
      service.status("waiting for start");
    } else if (cmd.kind == runtime::CommandKind::kStartProgram) {
      if (need_reset) {
        fmt::print("dualv run: start of '{}' refused: the last stop has not been reset\n",
                   cmd.program);
        continue;
      }
      if (std::string(cmd.program) == kStreamProgram) {
        fmt::print("dualv run: starting stream (key {}): following signed setpoints on {}\n",
                   cmd.key_id, runtime::kSetpointChannel);
        std::fflush(stdout);
        service.status(fmt::format("streaming (key {})", cmd.key_id));
        try {
          const RunResult r = run_one(nullptr);
          fmt::print(
              "dualv run: stream {}{}; setpoints: {} followed, {} refused by the loop, {} refused "
              "on receipt\n",
              r.ok ? "done" : "STOPPED", r.ok ? "" : ": " + r.failure, r.stream.accepted,
              r.stream.refused, commands.setpoints_refused());
          need_reset = need_reset || !r.ok;
          service.status(
              r.ok ? std::string("waiting for start (last: stream done)")
                   : fmt::format("stopped: stream: {}; waiting for a signed reset", r.failure));
        } catch (const std::exception& e) {
          fmt::print(stderr, "dualv run: stream refused: {}\n", e.what());
        }
        std::fflush(stdout);
        continue;
      }
      std::string file = cmd.program;
      if (!std::filesystem::exists(file)) file = default_config_dir() + "/" + cmd.program;
      if (!std::filesystem::exists(file)) file += ".yaml";
      try {
        trajectory::ProgramContext ctx;
        ctx.start = ctx.home = cfg.model.home;
        ctx.workspace = cfg.trajectory.limits.workspace;
        const trajectory::Program program = trajectory::load_program_file(file, ctx);
        trajectory::preflight_or_throw(cfg.model, program, cfg.trajectory.limits);
        if (stop_signal_received()) continue;  // ending: start nothing new
        fmt::print("dualv run: starting {} (key {})\n", file, cmd.key_id);
        const std::string name = std::filesystem::path(file).filename().string();
        service.status(fmt::format("running {} (key {})", name, cmd.key_id));
        const RunResult r = run_one(&program);
        fmt::print("dualv run: {} {}{}\n", file, r.ok ? "done" : "STOPPED",
                   r.ok ? "" : ": " + r.failure);
        need_reset = need_reset || !r.ok;
        service.status(
            r.ok ? fmt::format("waiting for start (last: {} done)", name)
                 : fmt::format("stopped: {}: {}; waiting for a signed reset", name, r.failure));
      } catch (const std::exception& e) {
        fmt::print(stderr, "dualv run: start of '{}' refused: {}\n", cmd.program, e.what());
      }
    }
    std::fflush(stdout);
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
  if (args.rate_hz > 0.0) cfg.loop.period_ns = static_cast<std::int64_t>(1e9 / args.rate_hz + 0.5);
  const std::string program_file =
      args.program.empty() ? default_config_dir() + "/paper.yaml" : args.program;
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
  std::unique_ptr<drivers::CanopenDrives> drives;
  if (!args.can.empty()) {
    if (args.variants.empty()) {  // on drives, the proposed method only unless asked
      variants.clear();
      variants.push_back(paper_variants().front());
    }
    const drivers::CanConfig can = drivers::load_can_config(YamlReader::load_file(cfg.path)["can"]);
    drivers::CanopenSetupOptions opts;
    opts.interface = args.can;
    opts.control_period_s = cfg.period();
    opts.log = [](const std::string& line) { fmt::print("  {}\n", line); };
    fmt::print("dualv run: booting the drives on {}\n", args.can);
    drives = drivers::open_canopen_drives(can, opts);
  }

  const std::string out = args.out.empty() ? default_out_dir() : args.out;
  std::filesystem::create_directories(out);
  fmt::print(
      "dualv run: {} ({} segments, {:.2f} s) on {} at {:.0f} Hz{}\n", program_file, program.size(),
      program.duration(),
      drives ? "the CANopen drives on " + args.can : std::string("the in-process simulated Dual-V"),
      cfg.rate_hz(), args.realtime || drives ? ", paced in real time" : ", simulated time");
  // Telemetry: an LCM log in the output folder (LCM's file provider: no network), or live.
  const std::string log_file = out + "/telemetry.lcmlog";
  runtime::TelemetryPublisher telemetry(args.lcm.empty() ? runtime::log_url(log_file) : args.lcm);
  telemetry.start();
  // Operator commands: e-stop from anyone, stop/reset signed with a key from the key folder.
  std::unique_ptr<runtime::CommandChannel> commands;
  const std::string command_url = !args.commands.empty() ? args.commands : args.lcm;
  if (!command_url.empty()) {
    const std::string key_dir = args.keys.empty() ? default_config_dir() + "/keys" : args.keys;
    std::vector<runtime::CommandKey> keys;
    if (std::filesystem::is_directory(key_dir)) {
      std::vector<std::string> warnings;
      keys = runtime::load_command_keys(key_dir, &warnings);
      for (const auto& w : warnings) fmt::print(stderr, "dualv run: {}\n", w);
    }
    fmt::print(
        "dualv run: listening for operator commands on {} ({} key(s) from {}; e-stop needs "
        "none)\n",
        command_url, keys.size(), key_dir);
    commands = std::make_unique<runtime::CommandChannel>(command_url,
                                                         runtime::CommandVerifier(std::move(keys)));
    commands->set_setpoint_check(setpoint_check(cfg));
    commands->start();
  }
  // Ctrl-C: a controlled stop (SS1), not a dropped robot; the idle service ends cleanly.
  install_stop_signal_handlers(args.serve);
  if (args.serve) {
    if (!commands) {
      fmt::print(stderr, "dualv run: --serve needs --commands URL (or --lcm URL)\n");
      return 2;
    }
    return serve(cfg, *commands, service, [&](const trajectory::Program* p) {
      RunOptions opts;
      opts.telemetry = &telemetry;
      opts.commands = commands.get();
      opts.service = &service;
      opts.fault_log_path = out + "/faults.jsonl";
      opts.realtime = true;
      if (!p)
        return drives ? run_stream(cfg, drives->actuators(), opts)
                      : run_stream_in_process(cfg, opts);
      return drives ? run_program(cfg, *p, paper_variants().front(), drives->actuators(), opts)
                    : run_in_process(cfg, *p, paper_variants().front(), opts);
    });
  }
  std::vector<RunResult> runs;
  // Frames sent before the program (boot, priming): the bus report below separates them.
  const std::uint64_t syncs_before = drives ? drives->actuators().counters().sync_sent : 0;
  const std::string program_name = std::filesystem::path(program_file).filename().string();
  service.ready(fmt::format("starting {}", program_name));
  for (const auto& v : variants) {
    if (stop_signal_received()) break;  // stopped by a signal: no further variant starts
    service.status(fmt::format("running {} ({})", program_name, v.name));
    RunOptions opts;
    opts.telemetry = &telemetry;
    opts.commands = commands.get();
    opts.service = &service;
    opts.fault_log_path = out + "/faults.jsonl";
    // A terminal gets one line rewritten in place; a log gets a line per second of robot time.
    const bool tty = isatty(fileno(stdout));
    opts.progress = [tty](const std::string& name, double t, double duration) {
      if (tty) {
        fmt::print("\r  {:<24} t = {:5.2f} / {:.2f} s", name, t, duration);
        std::fflush(stdout);
      } else if (std::fmod(t + 1e-9, 1.0) < 0.5) {
        fmt::print("  {:<24} t = {:5.2f} / {:.2f} s\n", name, t, duration);
      }
    };
    opts.realtime = args.realtime;
    runs.push_back(drives ? run_program(cfg, program, v, drives->actuators(), opts)
                          : run_in_process(cfg, program, v, opts));
    const RunResult& r = runs.back();
    fmt::print("{}  {:<24} {} in {:.2f} s wall ({:.0f}x real time){}\n", tty ? "\r" : "", v.name,
               r.ok ? "done" : "FAILED", r.wall_time, r.robot_time / std::max(r.wall_time, 1e-9),
               r.ok ? "" : ": " + r.failure);
  }
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
  if ((args.realtime || drives) && !runs.empty())
    fmt::print("\n{}", control::format_loop_stats(runs.back().loop));
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
  cmd->add_option("-p,--program", args.program,
                  "Program YAML (default: paper.yaml beside the config)");
  cmd->add_option("-o,--out", args.out, "Output folder (default: out/run-<date>-<time>)");
  cmd->add_option("--rate", args.rate_hz, "Control rate [Hz] (default: loop.rate_hz)")
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
                  "Receive operator commands (dualv estop/stop/reset) on this LCM URL (default: "
                  "the --lcm URL when given)");
  cmd->add_flag("--serve", args.serve,
                "Wait for signed `dualv start PROGRAM` commands and run them (the service mode); "
                "`dualv start stream` follows signed setpoints from `dualv stream` until a signed "
                "stop, or stops (SS1) when they cease for safety.watchdogs.command_stream_timeout");
  cmd->add_option("--keys", args.keys, "Folder of command keys (default: <config dir>/keys)");
  cmd->add_flag("--yes-move-hardware", args.move_hardware,
                "Confirm that --can on a real (non-vcan) interface may move the robot");
  cmd->callback([] { exit_code() = run(args); });
}

}  // namespace dualv::apps
