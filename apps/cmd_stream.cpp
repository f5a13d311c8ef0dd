// `dualv stream --key FILE (--circle R | --csv FILE)`: streams signed plate pose setpoints to
// a `dualv run --serve`. It first asks for a streaming run (`dualv start stream`, signed), then
// sends one setpoint per 1/rate s and, at the end, a signed stop (the robot comes to rest and
// holds; no fault). Killed or interrupted before the end, it sends nothing more: the robot's
// stream watchdog then stops it (SS1) and a signed reset is needed before the next start.
#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "apps/commands.hpp"
#include "common/config_error.hpp"
#include "runtime/channels.hpp"
#include "runtime/command_auth.hpp"
#include "runtime/command_channel.hpp"
#include "runtime/lcm_url.hpp"
#include "runtime/telemetry_publisher.hpp"

namespace dualv::apps {

namespace {

struct StreamArgs {
  std::string url = runtime::kLiveUrl;
  std::string key_file;
  double circle = 0.0;
  std::vector<double> centre{0.0, 0.25};
  double circle_period = 4.0;
  std::string csv;
  double rate = 100.0;
  double duration = -1.0;  // not given: 10 s for --circle, the file's length for --csv
  bool start = true;
  bool stop = true;
};

struct TimedPose {
  double t = 0.0;
  double x = 0.0, y = 0.0, theta = 0.0;
};

// CSV rows `t,x,y,theta` (s, m, m, rad), t increasing; a first line that is not numbers is a
// header. Each pose is sent from its time on (held until the next).
std::vector<TimedPose> load_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError({fmt::format("--csv {}: cannot open", path)});
  std::vector<TimedPose> out;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty() || line[0] == '#') continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream is(line);
    TimedPose p;
    if (!(is >> p.t >> p.x >> p.y >> p.theta)) {
      if (out.empty() && n == 1) continue;  // header
      throw ConfigError({fmt::format("--csv {} line {}: expected t,x,y,theta", path, n)});
    }
    if (!out.empty() && p.t <= out.back().t)
      throw ConfigError({fmt::format("--csv {} line {}: t must increase", path, n)});
    out.push_back(p);
  }
  if (out.empty()) throw ConfigError({fmt::format("--csv {}: no poses", path)});
  return out;
}

int stream(const StreamArgs& a) {
  if ((a.circle > 0.0) == !a.csv.empty()) {
    fmt::print(stderr, "dualv stream: give exactly one of --circle R or --csv FILE\n");
    return 2;
  }
  if (a.centre.size() != 2) {
    fmt::print(stderr, "dualv stream: --centre takes two numbers: x y [m]\n");
    return 2;
  }
  std::vector<TimedPose> csv;
  if (!a.csv.empty()) csv = load_csv(a.csv);
  // 0: until interrupted.
  const double duration = a.duration >= 0.0 ? a.duration : !csv.empty() ? csv.back().t : 10.0;
  std::vector<std::string> warnings;
  const runtime::CommandKey key = runtime::load_command_key(a.key_file, &warnings);
  for (const auto& w : warnings) fmt::print(stderr, "dualv stream: warning: {}\n", w);
  const std::string to = runtime::command_url(a.url);  // runtime/lcm_url.hpp
  auto lcm = runtime::open_lcm(to);
  if (a.start) {
    const auto sent =
        runtime::send_command(*lcm, runtime::CommandKind::kStartProgram, "stream", &key);
    fmt::print("dualv stream: stream start requested on {} (key '{}', sequence {})\n", to, key.id,
               sent.sequence);
  }
  fmt::print("dualv stream: {} setpoints/s for {} on {}\n", a.rate,
             duration > 0.0 ? fmt::format("{:.1f} s", duration) : std::string("ever"),
             runtime::kSetpointChannel);
  std::fflush(stdout);

  auto pose_at = [&](double t) {
    if (!csv.empty()) {
      auto it = std::upper_bound(csv.begin(), csv.end(), t,
                                 [](double tt, const TimedPose& p) { return tt < p.t; });
      const TimedPose& p = it == csv.begin() ? csv.front() : *(it - 1);
      return std::array<double, 3>{p.x, p.y, p.theta};
    }
    const double ang = 2.0 * M_PI * t / a.circle_period;
    return std::array<double, 3>{a.centre[0] + a.circle * std::cos(ang),
                                 a.centre[1] + a.circle * std::sin(ang), 0.0};
  };
  // Sequence: the wall clock in us, strictly increasing, so a later stream (another process)
  // is never taken for a replay of this one.
  std::int64_t sequence = 0;
  const auto period = std::chrono::duration<double>(1.0 / a.rate);
  const auto t0 = std::chrono::steady_clock::now();
  std::int64_t sent = 0;
  for (bool last = false; !last; ++sent) {
    const auto due = t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              period * static_cast<double>(sent));
    std::this_thread::sleep_until(due);
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // The final setpoint is the pose at `duration` itself (a file's last row is always sent).
    last = duration > 0.0 && t >= duration;
    sequence = std::max(runtime::wall_utime(), sequence + 1);
    const auto p = pose_at(last ? duration : t);
    runtime::send_setpoint(*lcm, p[0], p[1], p[2], sequence, &key);
  }
  if (a.stop) {
    runtime::send_command(*lcm, runtime::CommandKind::kStop, "", &key);
    fmt::print("dualv stream: {} setpoints sent; stop sent (the robot comes to rest and holds)\n",
               sent);
  } else {
    fmt::print("dualv stream: {} setpoints sent; no stop sent (--no-stop)\n", sent);
  }
  return 0;
}

}  // namespace

void register_stream_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "stream",
      "Stream signed plate pose setpoints to a `dualv run --serve` (teleoperation, tests): a "
      "signed `start stream`, the setpoints, a signed stop at the end; if the stream stops "
      "early (killed, network) the robot stops itself (SS1) after "
      "safety.watchdogs.command_stream_timeout");
  static StreamArgs args;
  cmd->add_option("--lcm", args.url, kRobotUrlHelp)->capture_default_str();
  cmd->add_option("--key", args.key_file,
                  "Key file (32 bytes; its name without extension is the key id)")
      ->required();
  cmd->add_option("--circle", args.circle, "Stream a circle of this radius [m]")
      ->check(CLI::Range(0.0, 0.2));
  cmd->add_option("--centre", args.centre, "Circle centre x y [m]")->capture_default_str();
  cmd->add_option("--circle-period", args.circle_period, "Time for one turn [s]")
      ->capture_default_str()
      ->check(CLI::Range(0.5, 1000.0));
  cmd->add_option("--csv", args.csv,
                  "Stream poses from a CSV file: t,x,y,theta per line (s, m, m, rad), each sent "
                  "from its time on");
  cmd->add_option("--rate", args.rate, "Setpoints per second")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1000.0));
  cmd->add_option("--duration", args.duration,
                  "Seconds to stream (default: 10 for --circle, the file's length for --csv; 0: "
                  "until interrupted)")
      ->check(CLI::Range(0.0, 1e6));
  cmd->add_flag("!--no-start", args.start,
                "Do not send `start stream` first (a stream is already running)");
  cmd->add_flag("!--no-stop", args.stop, "Do not send a stop at the end");
  cmd->callback([] { exit_code() = stream(args); });
}

}  // namespace dualv::apps
