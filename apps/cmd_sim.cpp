// `dualv sim --can IFACE`: the drive emulator (sim/drive_emulator.hpp) and the simulated
// plant as their own process on a SocketCAN interface: four CiA 402 drives that a master
// (`dualv run --can IFACE`, or candump/cansend by hand) boots and drives over the bus.
//
// Non-real-time loop: wait_readable until a frame comes or the emulator's next timer is due
// (DriveEmulator::next_due_ns: heartbeats, consumer timeouts, RPDO deadlines, event TPDOs)
// -> poll(CLOCK_MONOTONIC) -> the answers sent in one batch (drivers/can/batching_bus.hpp);
// one wake-up per burst of frames and none between them. The plant
// advances by the actual spacing of the SYNCs received (kernel receive timestamps), so it
// moves in real time whatever period the master runs at. A foreign drive (a vendor stack
// this project did not write) is emulated with --upload-without-size (expedited SDO
// uploads e=1, s=0) and --absent OBJ (the drive lacks that object, e.g. 0x60C2); --foreign
// sets both (uploads without size, no 60C2h); --no-dummy-mapping: drives that cannot map dummy
// entries (the broadcast and fd layouts, issue 15); --no-fd: classic drives (PDOs end at 8
// bytes, so the fd layout is refused at boot). With can.bus_layout: fd the drives speak CAN FD
// and the socket carries FD frames (the interface needs MTU 72). --eds FILE takes the drives'
// objects from an EDS (sim/canopen/eds_dictionary.hpp: what the EDS lacks is absent, 1018h identity
// from its defaults; an EDS entry the emulator does not implement alike is refused). Exits cleanly
// (status 0) on SIGINT/SIGTERM, --exit-after or --exit-when-idle. Test hooks: --estop-after
// presses the e-stop input of every drive, --fault-after raises a drive fault with an EMCY
// code, and so does SIGUSR1 (at a moment a test chooses, e.g. while a program runs: drive
// --fault-drive, code --fault-code). With --times-from-enable their times count from the first
// drive in Operation Enabled (a line says when), so a test injects a set time into the motion
// however long the master took to boot the drives.
#include <fmt/core.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "apps/commands.hpp"
#include "apps/config_path.hpp"
#include "control/config/model_config.hpp"
#include "drivers/can/batching_bus.hpp"
#include "drivers/can/socketcan_bus.hpp"
#include "drivers/canopen_config.hpp"
#include "firmware_if/eds.hpp"
#include "sim/canopen/eds_dictionary.hpp"
#include "sim/drive_emulator.hpp"
#include "sim/plant.hpp"

namespace dualv::apps {

namespace {

volatile std::sig_atomic_t g_stop = 0;
volatile std::sig_atomic_t g_fault = 0;
void on_stop_signal(int) { g_stop = 1; }
void on_fault_signal(int) { g_fault = 1; }

struct SimArgs {
  std::string config;
  std::string interface;
  double estop_after = -1.0;
  double estop_release_after = -1.0;
  double fault_after = -1.0;
  int fault_drive = 0;
  std::string fault_code = "0x2310";
  double exit_after = -1.0;
  double exit_when_idle = -1.0;
  double status_every = 1.0;
  int rpdo_watchdog = -1;
  double free_run_after = -1.0;
  bool plant_step_nominal = false;
  bool times_from_enable = false;  // the hooks' times count from the first Operation Enabled
  bool segmented_upload = false;
  bool upload_without_size = false;
  bool no_dummy_mapping = false;
  bool no_fd = false;
  std::vector<std::string> absent;
  bool foreign = false;
  std::string eds;  // --eds FILE: the drives' object dictionary from an EDS (CiA 306)
};

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: poll() in wait_readable returns at once
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  sa.sa_handler = on_fault_signal;
  sigaction(SIGUSR1, &sa, nullptr);
}

std::string status_line(const sim::DriveEmulator& emu, double t) {
  std::string s =
      fmt::format("sim t={:.2f}s sync={} plant={:.3f}s", t, emu.syncs(), emu.plant().output().time);
  for (int i = 0; i < emu.size(); ++i) {
    const sim::EmulatedDriveStatus d = emu.status(i);
    s += fmt::format(" | {}:{}/{} sw={:04X} {:+.2f}Nm", d.node_id, to_string(d.nmt),
                     fw::to_string(d.state), d.statusword, d.torque_nm);
    if (d.error_code != 0) s += fmt::format(" err={:04X}", d.error_code);
    if (d.heartbeat_lost) s += " hb-lost";
  }
  s += emu.estop_pressed() ? " | ESTOP pressed" : "";
  return s;
}

int run_sim(const SimArgs& a) {
  const std::string file = resolve_config(a.config);
  const model::Model model = model::load_model_file(file);
  drivers::CanConfig can = drivers::load_can_config_file(file);
  if (!a.interface.empty()) can.interface = a.interface;
  sim::DriveEmulatorConfig emu_cfg = sim::emulator_config_from(can);
  if (a.rpdo_watchdog >= 0)
    emu_cfg.rpdo_watchdog_cycles = static_cast<std::uint32_t>(a.rpdo_watchdog);
  emu_cfg.plant_step_nominal = a.plant_step_nominal;
  if (a.free_run_after >= 0)
    emu_cfg.free_run_after_ns = static_cast<std::uint64_t>(std::llround(a.free_run_after * 1e9));
  emu_cfg.segmented_upload = a.segmented_upload;
  emu_cfg.upload_without_size = a.upload_without_size || a.foreign;
  emu_cfg.refuse_dummy_mapping = a.no_dummy_mapping;
  if (a.no_fd) emu_cfg.fd = false;
  std::vector<std::string> absent = a.absent;
  if (a.foreign) absent.push_back("0x60C2");
  for (const std::string& o : absent) {
    unsigned long idx = 0x10000;
    try {
      idx = std::stoul(o, nullptr, 0);
    } catch (const std::exception&) {
    }
    if (idx > 0xFFFF) {
      fmt::print(stderr, "dualv sim: --absent {}: not an object index (e.g. 0x60C2)\n", o);
      return 2;
    }
    emu_cfg.absent_objects.push_back(static_cast<std::uint16_t>(idx));
  }
  std::optional<fw::eds::Eds> eds;
  if (!a.eds.empty()) {
    eds = fw::eds::read_eds_file(a.eds);  // EdsError: file:line: reason
    const sim::canopen::EdsDrive d =
        sim::canopen::drive_from_eds(*eds, emu_cfg.vendor_id, emu_cfg.product_code);
    emu_cfg.absent_objects.insert(emu_cfg.absent_objects.end(), d.absent_objects.begin(),
                                  d.absent_objects.end());
    emu_cfg.vendor_id = d.vendor_id;
    emu_cfg.product_code = d.product_code;
  }
  unsigned long fault_code = 0;
  try {
    fault_code = std::stoul(a.fault_code, nullptr, 0);
  } catch (const std::exception&) {
    fault_code = 0x10000;
  }
  if (fault_code > 0xFFFF) {
    fmt::print(stderr, "dualv sim: --fault-code {}: not a 16-bit EMCY code (e.g. 0x2310)\n",
               a.fault_code);
    return 2;
  }
  if (a.fault_drive < 0 || a.fault_drive >= static_cast<int>(emu_cfg.drives.size())) {
    fmt::print(stderr, "dualv sim: --fault-drive {}: drives are 0..{}\n", a.fault_drive,
               emu_cfg.drives.size() - 1);
    return 2;
  }
  sim::Plant plant(model, sim::emulator_plant_config(sim::load_plant_config_file(file), emu_cfg));
  drivers::SocketCanConfig bus_cfg;
  bus_cfg.interface = can.interface;
  bus_cfg.fd_frames = can.bus_layout == fw::BusLayout::kFd;
  drivers::SocketCanBus bus(bus_cfg);
  drivers::BatchingBus batched(bus);
  std::unique_ptr<sim::DriveEmulator> emu_owner;
  try {
    emu_owner = std::make_unique<sim::DriveEmulator>(batched, plant, emu_cfg);
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "dualv sim: {}\n", e.what());
    return 2;
  }
  sim::DriveEmulator& emu = *emu_owner;
  if (eds) {
    // Every drive is built alike: drive 0 has the entries of all.
    std::vector<std::string> diff = sim::canopen::differences(*eds, emu.dictionary(0));
    if (!diff.empty()) {
      fmt::print(stderr, "dualv sim: --eds {}: the emulator cannot be this drive:\n", a.eds);
      for (const std::string& d : diff) fmt::print(stderr, "  {}\n", d);
      return 2;
    }
    fmt::print("dualv sim: object dictionary from {} ({} objects)\n", a.eds, eds->objects.size());
  }

  install_signal_handlers();
  std::string nodes;
  for (const auto& d : emu_cfg.drives)
    nodes += (nodes.empty() ? "" : ",") + std::to_string(d.node_id);
  fmt::print("dualv sim: {} drives (nodes {}) on {}, SYNC period {:.3f} ms, RPDO watchdog {}\n",
             emu.size(), nodes, can.interface, static_cast<double>(emu_cfg.sync_period_ns) * 1e-6,
             emu_cfg.rpdo_watchdog_cycles ? fmt::format("{} cycles", emu_cfg.rpdo_watchdog_cycles)
                                          : std::string("off"));
  if (emu_cfg.upload_without_size || !emu_cfg.absent_objects.empty()) {
    std::string objs;
    for (std::uint16_t o : emu_cfg.absent_objects)
      objs += fmt::format("{}{:04X}h", objs.empty() ? "" : ", ", o);
    fmt::print("dualv sim: foreign drive: SDO uploads {}, objects absent: {}\n",
               emu_cfg.upload_without_size ? "without size (e=1, s=0)" : "with size",
               objs.empty() ? "none" : objs);
  }
  std::fflush(stdout);

  using Clock = std::chrono::steady_clock;
  const Clock::time_point t0 = Clock::now();
  auto now_ns = [&] {
    return static_cast<std::uint64_t>(
               std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - t0).count()) +
           1;
  };
  auto seconds = [](std::uint64_t ns) { return static_cast<double>(ns) * 1e-9; };
  emu.poll(now_ns());  // power on: boot-up messages
  (void)batched.flush();
  fmt::print("dualv sim: drives booted (boot-up sent)\n");
  std::fflush(stdout);

  bool estop_done = false, release_done = false, fault_done = false;
  // The test hooks' time base: the emulator's start, or (--times-from-enable) the first drive
  // in Operation Enabled, unknown (kNever) until then.
  std::uint64_t hooks_from = a.times_from_enable ? sim::DriveEmulator::kNever : 0;
  double next_status = a.status_every > 0 ? a.status_every : -1.0;
  const char* reason = "signal";
  // Sleeps until a frame arrives or the next thing is due (the emulator's timers, the test
  // hooks, the status line), at most 100 ms: one wake-up per burst of frames, none in between.
  auto due_at = [](double s) {
    return s >= 0 ? static_cast<std::uint64_t>(std::llround(s * 1e9)) : sim::DriveEmulator::kNever;
  };
  auto hook_due = [&](double s) {
    return s < 0 || hooks_from == sim::DriveEmulator::kNever ? sim::DriveEmulator::kNever
                                                             : hooks_from + due_at(s);
  };
  std::uint64_t before = now_ns();
  while (g_stop == 0) {
    std::uint64_t wake = std::min(emu.next_due_ns(before), before + 100'000'000u);
    if (!estop_done) wake = std::min(wake, hook_due(a.estop_after));
    if (!release_done) wake = std::min(wake, hook_due(a.estop_release_after));
    if (!fault_done) wake = std::min(wake, hook_due(a.fault_after));
    wake = std::min({wake, due_at(next_status), due_at(a.exit_after)});
    if (a.exit_when_idle > 0) wake = std::min(wake, emu.last_frame_ns() + due_at(a.exit_when_idle));
    if (wake > before) bus.wait_readable(std::chrono::nanoseconds(wake - before));
    const std::uint64_t now = now_ns();
    before = now;  // the next wait is computed from here (a clock read less per wake-up)
    emu.poll(now);
    const double t = seconds(now);
    if (bus.state() == drivers::BusStatus::kBusOff && batched.restart() == drivers::BusStatus::kOk)
      fmt::print("dualv sim: bus-off, restarted\n");
    if (hooks_from == sim::DriveEmulator::kNever)
      for (int i = 0; i < emu.size(); ++i)
        if (emu.status(i).state == fw::Cia402State::kOperationEnabled) {
          hooks_from = now;
          fmt::print(
              "dualv sim: t={:.3f}s operation enabled (node {}): test hooks count from here\n", t,
              emu.status(i).node_id);
          break;
        }
    const bool hooks_on = hooks_from != sim::DriveEmulator::kNever;
    const double th = hooks_on ? seconds(now - hooks_from) : -1.0;  // the hooks' time
    if (a.estop_after >= 0 && !estop_done && hooks_on && th >= a.estop_after) {
      emu.press_estop(true);
      estop_done = true;
      fmt::print("dualv sim: t={:.3f}s e-stop input pressed (60FDh bit {})\n", t,
                 fw::od::kDigitalInputEstopBit);
    }
    if (a.estop_release_after >= 0 && !release_done && hooks_on && th >= a.estop_release_after) {
      emu.press_estop(false);
      release_done = true;
      fmt::print("dualv sim: t={:.3f}s e-stop input released\n", t);
    }
    const bool fault_signal = g_fault != 0;
    const bool fault_timed = a.fault_after >= 0 && !fault_done && hooks_on && th >= a.fault_after;
    if (fault_signal || fault_timed) {
      g_fault = 0;
      fault_done = fault_done || fault_timed;
      emu.inject_fault(a.fault_drive, static_cast<std::uint16_t>(fault_code));
      fmt::print("dualv sim: t={:.3f}s fault {:04X}h ({}) injected on drive {}{}\n", t, fault_code,
                 fw::emcy_text(static_cast<std::uint16_t>(fault_code)), a.fault_drive,
                 fault_signal ? " (SIGUSR1)" : "");
    }
    if (next_status > 0 && t >= next_status) {
      fmt::print("{}\n", status_line(emu, t));
      next_status += a.status_every;
    }
    // Every frame of this wake-up in one sendmmsg: the answers, and the EMCY of a fault or
    // e-stop injected above (at once, not at the next wake-up).
    (void)batched.flush();
    std::fflush(stdout);
    if (a.exit_after >= 0 && t >= a.exit_after) {
      reason = "--exit-after";
      break;
    }
    if (a.exit_when_idle > 0) {
      const std::uint64_t last = emu.last_frame_ns();
      if (t - seconds(last) >= a.exit_when_idle) {
        reason = "--exit-when-idle";
        break;
      }
    }
  }
  fmt::print("{}\n", status_line(emu, seconds(now_ns())));
  fmt::print(
      "dualv sim: stopped ({}), {} SYNCs, {} virtual SYNCs (free run), {} frames not for "
      "these drives\n",
      reason, emu.syncs(), emu.virtual_syncs(), emu.unhandled_frames());
  for (int i = 0; i < emu.size(); ++i) {
    const sim::EmulatedDriveCounters c = emu.status(i).counters;
    fmt::print(
        "dualv sim: node {}: {} RPDOs ({} too short), {} TPDOs, {} SDO requests ({} aborted), "
        "{} EMCYs, RPDO watchdog trips {}, RPDO deadline trips {}, heartbeat losses {}, "
        "send failures {}\n",
        emu.status(i).node_id, c.rpdos, c.rpdo_length_errors, c.tpdos_sent, c.sdo_requests,
        c.sdo_aborts_sent, c.emcy_sent, c.watchdog_trips, c.deadline_trips, c.heartbeat_losses,
        c.tx_failures);
  }
  std::fflush(stdout);
  return 0;
}

}  // namespace

void register_sim_command(CLI::App& app) {
  auto args = std::make_shared<SimArgs>();
  CLI::App* cmd = app.add_subcommand(
      "sim", "Emulate the CiA 402 drives and the Dual-V mechanism on a CAN interface");
  add_config_option(*cmd, args->config);
  cmd->add_option("--can", args->interface, "SocketCAN interface (default: can.interface)");
  cmd->add_option("--estop-after", args->estop_after,
                  "Press the e-stop input (60FDh) of every drive after S seconds");
  cmd->add_option("--estop-release-after", args->estop_release_after,
                  "Release the e-stop input after S seconds");
  cmd->add_option("--fault-after", args->fault_after,
                  "Raise a drive fault after S seconds (SIGUSR1 raises it at once)");
  cmd->add_option("--fault-drive", args->fault_drive, "Drive (0..n-1) for --fault-after / SIGUSR1");
  cmd->add_option("--fault-code", args->fault_code,
                  "EMCY code for --fault-after / SIGUSR1 (0x2310)");
  cmd->add_option("--exit-after", args->exit_after, "Exit after S seconds");
  cmd->add_option("--exit-when-idle", args->exit_when_idle,
                  "Exit when no frame has arrived for S seconds");
  cmd->add_option("--status-every", args->status_every,
                  "Print a status line every S seconds (0: never)");
  cmd->add_option("--rpdo-watchdog", args->rpdo_watchdog,
                  "Drive-side RPDO watchdog in SYNC cycles (0: off; default 3)");
  cmd->add_option("--free-run-after", args->free_run_after,
                  "Advance the mechanism without SYNC (a dead master) after S seconds of silence "
                  "(0: never; default 0.05)");
  cmd->add_flag("--plant-step-nominal", args->plant_step_nominal,
                "Advance the mechanism by 1006h per SYNC, not by the SYNCs' spacing (test guests "
                "frozen as a whole by their host)");
  cmd->add_flag("--times-from-enable", args->times_from_enable,
                "--estop-after, --estop-release-after and --fault-after count from the first drive "
                "in Operation Enabled (logged), not from the start");
  cmd->add_flag("--segmented-upload", args->segmented_upload,
                "Answer every SDO upload with a segmented transfer");
  cmd->add_flag("--upload-without-size", args->upload_without_size,
                "Answer expedited SDO uploads without size indication (e=1, s=0)");
  cmd->add_flag("--no-dummy-mapping", args->no_dummy_mapping,
                "Drives that cannot map CiA 301 dummy entries (abort 06040041h): the broadcast "
                "and fd layouts (can.bus_layout) are refused at boot");
  cmd->add_flag("--no-fd", args->no_fd,
                "Classic CAN drives: a PDO mapping beyond 8 bytes is aborted (06040042h), so "
                "can.bus_layout: fd is refused at boot");
  cmd->add_option("--absent", args->absent,
                  "An object the drives lack (SDO abort 06020000h), e.g. 0x60C2; repeatable");
  cmd->add_flag("--foreign", args->foreign,
                "Emulate a foreign drive: --upload-without-size --absent 0x60C2");
  cmd->add_option("--eds", args->eds,
                  "Take the drives' object dictionary from an EDS (CiA 306), e.g. "
                  "config/eds/dualv-emulated-drive.eds: objects it lacks are absent")
      ->check(CLI::ExistingFile);
  cmd->callback([args] { exit_code() = run_sim(*args); });
}

}  // namespace dualv::apps
