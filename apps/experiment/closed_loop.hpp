#pragma once
// The closed-loop experiment: a program run by the control cycle against the simulated
// Dual-V, in-process and deterministic (simulated time, no sleeping), with the per-shape
// figures the paper reports (section V): tracking error, torques, torque steps, internal torque.
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "apps/experiment/robot_config.hpp"
#include "control/loop/cycle_stats.hpp"
#include "control/trajectory/program.hpp"
#include "drivers/actuator_set.hpp"
#include "runtime/command_channel.hpp"
#include "runtime/service_notifier.hpp"
#include "runtime/telemetry_publisher.hpp"

namespace dualv::apps {

struct Variant {
  std::string name;  // e.g. "retimed"
  trajectory::TimingKind timing = trajectory::TimingKind::kRetimed;
  bool projection = true;
  bool feedforward = true;
};

// The paper's comparison: proposed (retimed + projection) against the original clock, plus
// the ablations of projection and feedforward.
std::vector<Variant> paper_variants();

// One control cycle, reduced to what the figures and metrics need.
struct Row {
  double t = 0.0;  // program time [s]
  int segment = 0;
  model::Pose X_d = model::Pose::Zero();
  model::Pose X = model::Pose::Zero();            // estimated (forward kinematics of the encoders)
  std::array<double, drivers::kMaxDrives> tau{};  // torque sent [N m]
  double tau_internal = 0.0;                      // |N tau| of the command at the estimate [N m]
  double plant_internal = 0.0;  // |N tau| of the torque the simulated motors apply [N m]
  double lambda = 0.0, lambda_dot = 0.0, lambda_dd = 0.0;
};

struct SegmentMetrics {
  std::size_t segment = 0;
  std::string label;  // e.g. "circle"
  trajectory::SegmentKind kind = trajectory::SegmentKind::kDwell;
  double max_error_x_mm = 0.0, max_error_y_mm = 0.0;
  double max_error_mm = 0.0, rms_error_mm = 0.0;    // |(x, y)| error
  double t_max_error_x = 0.0, t_max_error_y = 0.0;  // program time of the maxima [s]
  double t_max_error = 0.0;
  std::array<double, drivers::kMaxDrives> peak_tau{};
  double max_tau_step = 0.0;  // largest |tau_k - tau_k-1| of any motor [N m]
  double rms_internal = 0.0;  // RMS |N tau| of the commands [N m]
  int cycles = 0;
};

// What a streaming run (run_stream) did with the setpoints it received.
struct StreamStats {
  bool streamed = false;       // the run followed a stream
  std::uint64_t accepted = 0;  // setpoints the streaming reference took
  std::uint64_t refused = 0;   // refused by the reference: non-finite, outside, after the end
  std::uint64_t ignored = 0;   // setpoints received while no stream was running
  bool ended_by_stop = false;  // a signed stop ended the stream normally (hold, no fault)
};

struct RunResult {
  control::LoopStatsSummary loop;  // cycle time and lateness of the loop
  Variant variant;
  int n = 0;
  std::vector<Row> rows;
  std::vector<SegmentMetrics> segments;  // one per program segment
  SegmentMetrics shapes;                 // all shape segments together
  // Every cycle of the run: moves, dwells, the settling after the program and the ringing
  // after each shape, which the per-shape windows leave out.
  SegmentMetrics program;
  double robot_time = 0.0;  // [s]
  double wall_time = 0.0;   // [s]
  bool ok = true;
  std::string failure;  // why the run stopped early
  // The loop cycle that took the reference (cycle numbers in the fault log and telemetry
  // count from the loop's start; RunOptions::before_cycle's from this one).
  std::int64_t first_cycle = -1;
  StreamStats stream;
};

struct RunOptions {
  double settle_time = 0.2;  // [s] held at the final pose after the program
  // In-process simulation only: false = simulated time, as fast as the CPU allows
  // (deterministic); true = paced by the monotonic clock at the configured rate (SCHED_FIFO
  // etc. when permitted), as on a target. Drives on a bus are always paced by the clock.
  bool realtime = false;
  // Telemetry (robot state every cycle, loop statistics at the end) goes to this publisher's
  // queue when set: an LCM log by default (`dualv run`), or live with --lcm URL.
  runtime::TelemetryPublisher* telemetry = nullptr;
  // Operator commands (e-stop, stop, reset) received over LCM and verified; polled every
  // cycle by the loop (lock-free) when set.
  runtime::CommandChannel* commands = nullptr;
  // Safety events (fault log) are appended to this JSON-lines file by a non-RT thread when set.
  std::string fault_log_path;
  // Every cycle calls its beat() (an atomic add) when set: the systemd watchdog pings only
  // while the loop runs, so a hung loop gets the service killed.
  runtime::ServiceNotifier* service = nullptr;
  std::function<void(const std::string& variant, double t, double duration)> progress;
  // Streaming runs: the longest a stream may last [s]; time series rows are kept for at most
  // max_stream_rows cycles (the run goes on without recording after that).
  double max_stream_time = 3600.0;
  std::int64_t max_stream_rows = 120'000;
  // Tests and simulations only: called before every cycle with the loop's cycle number
  // (e.g. to publish a setpoint in simulated time), on stepped (simulated-time) machines.
  std::function<void(std::int64_t cycle)> before_cycle;
};

// One program, or one stream, on a machine of its own (apps/experiment/machine.hpp: the one
// control loop started, the reference followed, the loop shut down). A process that runs
// several (dualv run's variants, the service) keeps one Machine instead.
//
// `program` (rebased onto the simulated robot's actual pose) with the variant's timing law
// and controller switches against the in-process simulation of config.plant.
RunResult run_in_process(const RobotConfig& config, const trajectory::Program& program,
                         const Variant& variant, const RunOptions& options = {});

// The same program against any drives (e.g. CANopen drives on a SocketCAN interface),
// always paced by the monotonic clock.
RunResult run_program(const RobotConfig& config, const trajectory::Program& program,
                      const Variant& variant, drivers::ActuatorSet& io, const RunOptions& options);

// A streaming run (`dualv start stream`): the robot follows the signed pose setpoints that
// options.commands receives (runtime/command_channel.hpp), through the streaming reference
// (control/trajectory/streaming_reference.hpp) within config.trajectory.streaming and inside
// config.trajectory.limits.workspace. A signed stop ends it normally (the reference comes to
// rest, held for options.settle_time); a stream silent for
// safety.watchdogs.command_stream_timeout stops it (SS1, kCommandStreamStale). Needs
// options.commands (std::invalid_argument otherwise).
RunResult run_stream(const RobotConfig& config, drivers::ActuatorSet& io,
                     const RunOptions& options);
// The same against the in-process simulation.
RunResult run_stream_in_process(const RobotConfig& config, const RunOptions& options);

// SIGINT / SIGTERM latch an e-stop (StopSource::kSignal: SS1 of a moving robot) in the control
// loop of the running Machine and set stop_signal_received(), on which the supervisors end;
// a second signal, or a signal while no loop runs, ends the process at once, unless
// `exit_when_idle`: then it only sets the flag (the --serve supervisor polls it and ends
// cleanly, telling systemd STOPPING=1). Defined in machine.cpp.
void install_stop_signal_handlers(bool exit_when_idle = false);
// True once SIGINT or SIGTERM arrived (during a run or, with exit_when_idle, between runs).
bool stop_signal_received() noexcept;

// Metrics from rows (used for any backend: in-process, CAN).
void compute_metrics(const trajectory::Program& program, RunResult& result);

}  // namespace dualv::apps
