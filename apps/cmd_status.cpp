// `dualv status`: the robot's live state from LCM (what lcm-spy would show;
// Debian's lcm-spy does not start on Java 17). Reads any LCM URL, including a
// log: --lcm 'file:///path/run.lcmlog?speed=0'.
#include <fmt/core.h>

#include <chrono>
#include <csignal>
#include <lcm/lcm-cpp.hpp>
#include <optional>
#include <string>

#include "apps/commands.hpp"
#include "dualv_lcm/fault_event_t.hpp"
#include "dualv_lcm/loop_stats_t.hpp"
#include "dualv_lcm/robot_state_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/lcm_url.hpp"

namespace dualv::apps {

namespace {

volatile std::sig_atomic_t g_interrupted = 0;
void on_sigint(int) { g_interrupted = 1; }

const char* safety_name(int s) {
  using M = dualv_lcm::robot_state_t;
  switch (s) {
    case M::SAFETY_DISABLED:
      return "DISABLED";
    case M::SAFETY_OPERATIONAL:
      return "OPERATIONAL";
    case M::SAFETY_SS1:
      return "SS1 (stopping)";
    case M::SAFETY_STO:
      return "STO (torque off)";
    case M::SAFETY_ESTOP:
      return "E-STOP";
    case M::SAFETY_FAULT:
      return "FAULT";
  }
  return "UNKNOWN";
}

std::string flag_names(int f) {
  using M = dualv_lcm::robot_state_t;
  std::string s;
  auto add = [&](int bit, const char* name) {
    if ((f & bit) != 0) s += std::string(s.empty() ? "" : " ") + name;
  };
  add(M::FLAG_SIMULATED, "simulated");
  add(M::FLAG_ESTOP_LATCHED, "estop-latched");
  add(M::FLAG_DEADLINE_MISSED, "deadline-missed");
  add(M::FLAG_TELEMETRY_DROPPED, "telemetry-dropped");
  add(M::FLAG_PROGRAM_RUNNING, "program-running");
  add(M::FLAG_DRIVES_ENABLED, "drives-enabled");
  add(M::FLAG_STREAMING, "streaming");
  return s.empty() ? "-" : s;
}

// Decodes on our side, with try/catch: lcm-gen decoders throw on some corrupt
// lengths, and an exception must not unwind through LCM's C code.
template <typename Msg>
std::optional<Msg> decode(const lcm_recv_buf_t* rbuf) {
  Msg m;
  try {
    if (m.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) ==
        static_cast<int>(rbuf->data_size))
      return m;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

struct Monitor {
  std::optional<dualv_lcm::robot_state_t> state;
  std::optional<dualv_lcm::fault_event_t> fault;
  std::optional<dualv_lcm::loop_stats_t> stats;
  int malformed = 0;
  bool fresh_state = false;

  // C callbacks (LCM's C API; see runtime/command_channel.hpp for why).
  static void on_state(const lcm_recv_buf_t* b, const char*, void* user) {
    auto* self = static_cast<Monitor*>(user);
    if (auto m = decode<dualv_lcm::robot_state_t>(b)) {
      self->state = std::move(m);
      self->fresh_state = true;
    } else {
      ++self->malformed;
    }
  }
  static void on_fault(const lcm_recv_buf_t* b, const char*, void* user) {
    auto* self = static_cast<Monitor*>(user);
    if (auto m = decode<dualv_lcm::fault_event_t>(b))
      self->fault = std::move(m);
    else
      ++self->malformed;
  }
  static void on_stats(const lcm_recv_buf_t* b, const char*, void* user) {
    auto* self = static_cast<Monitor*>(user);
    if (auto m = decode<dualv_lcm::loop_stats_t>(b))
      self->stats = std::move(m);
    else
      ++self->malformed;
  }
};

void print(const Monitor& mon) {
  const auto& s = *mon.state;
  fmt::print("cycle {}  t = {:.3f} s  safety: {} ({})  flags: {}\n", s.cycle, s.t,
             safety_name(s.safety_state), s.safety_text, flag_names(s.status_flags));
  fmt::print("  joint   q [rad]   q_dot [rad/s]   tau [N m]   tau_internal [N m]\n");
  for (int i = 0; i < s.n; ++i) {
    auto at = [&](const std::vector<double>& v) {
      return i < static_cast<int>(v.size()) ? v[i] : 0.0;
    };
    fmt::print("  {:>5} {:>9.4f} {:>15.4f} {:>11.3f} {:>20.3f}\n", i + 1, at(s.q), at(s.q_dot),
               at(s.tau_cmd), at(s.tau_internal));
  }
  fmt::print("  plate X   = ({:+.4f} m, {:+.4f} m, {:+.4f} rad)\n", s.X[0], s.X[1], s.X[2]);
  fmt::print("  plate X_d = ({:+.4f} m, {:+.4f} m, {:+.4f} rad)\n", s.X_d[0], s.X_d[1], s.X_d[2]);
  fmt::print("  tracking error = ({:+.3f} mm, {:+.3f} mm, {:+.3f} mrad)\n",
             s.tracking_error[0] * 1e3, s.tracking_error[1] * 1e3, s.tracking_error[2] * 1e3);
  if ((s.status_flags & dualv_lcm::robot_state_t::FLAG_STREAMING) != 0)
    fmt::print(
        "  streaming: target ({:+.4f} m, {:+.4f} m, {:+.4f} rad), last setpoint {:.0f} ms ago, "
        "{} accepted, {} refused\n",
        s.stream_target[0], s.stream_target[1], s.stream_target[2], s.stream_age * 1e3,
        s.stream_accepted, s.stream_refused);
  else if (s.segment >= 0)
    fmt::print("  program segment {}  lambda = {:.4f}\n", s.segment, s.lambda);
  else
    fmt::print("  no program running\n");
  if (mon.stats) {
    const auto& l = *mon.stats;
    fmt::print(
        "  loop: {} cycles at {:.0f} Hz, cycle median {:.1f} us p99.9 {:.1f} us max {:.1f} "
        "us, lateness max {:.1f} us, {} deadline misses{}\n",
        l.cycles, l.period_ns > 0 ? 1e9 / static_cast<double>(l.period_ns) : 0.0,
        static_cast<double>(l.cycle_median_ns) * 1e-3, static_cast<double>(l.cycle_p999_ns) * 1e-3,
        static_cast<double>(l.cycle_max_ns) * 1e-3, static_cast<double>(l.lateness_max_ns) * 1e-3,
        l.deadline_misses, l.realtime ? "" : " (not real-time)");
  }
  if (mon.fault)
    fmt::print("  last fault (cycle {}): {} -> {}{}\n", mon.fault->cycle, mon.fault->cause,
               mon.fault->reaction, mon.fault->text.empty() ? "" : ": " + mon.fault->text);
  if (mon.malformed > 0) fmt::print("  {} malformed messages ignored\n", mon.malformed);
}

}  // namespace

void register_status_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("status", "Show the robot's live state from LCM");
  static std::string url = runtime::kLiveUrl;
  static double timeout_s = 3.0;
  static bool follow = false;
  cmd->add_option("--lcm", url, "LCM URL to listen on (a log: 'file:///path.lcmlog?speed=0')")
      ->capture_default_str();
  cmd->add_option("--timeout", timeout_s, "Seconds to wait for the first state")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_flag("-f,--follow", follow, "Keep printing (10 Hz) until Ctrl-C");
  cmd->callback([] {
    auto lcm = runtime::open_lcm(url);
    Monitor mon;
    lcm_t* c = lcm->getUnderlyingLCM();
    lcm_subscribe(c, runtime::kStateChannel, &Monitor::on_state, &mon);
    lcm_subscribe(c, runtime::kFaultChannel, &Monitor::on_fault, &mon);
    lcm_subscribe(c, runtime::kLoopStatsChannel, &Monitor::on_stats, &mon);
    std::signal(SIGINT, on_sigint);

    using Clock = std::chrono::steady_clock;
    const auto first_deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    auto next_print = Clock::now();
    auto last_state = Clock::now();
    while (g_interrupted == 0) {
      const int rc = lcm->handleTimeout(50);
      if (rc < 0) {
        // The file provider ends a log this way; anything else is an LCM error.
        break;
      }
      const auto now = Clock::now();
      if (!mon.state) {
        if (now > first_deadline) break;
        continue;
      }
      if (mon.fresh_state) last_state = now;
      if (!follow) {
        // One snapshot: let the rest of a burst (faults, stats) arrive first.
        lcm->handleTimeout(20);
        print(mon);
        return;
      }
      if (now >= next_print && mon.fresh_state) {
        fmt::print("\n");
        print(mon);
        mon.fresh_state = false;
        next_print = now + std::chrono::milliseconds(100);
      }
      if (now - last_state > std::chrono::duration<double>(timeout_s)) {
        fmt::print(stderr,
                   "dualv status: no state for {:.1f} s: the robot process stopped or "
                   "the network dropped\n",
                   timeout_s);
        exit_code() = 1;
        return;
      }
    }
    if (mon.state) {
      if (!follow) print(mon);
      return;
    }
    fmt::print(stderr,
               "dualv status: no robot state on {} at {} within {:.1f} s.\n"
               "  Is `dualv run --lcm '{}'` running? Both sides need the same URL; between two\n"
               "  machines use ttl=1 and a multicast route on the NIC facing the robot PC.\n",
               runtime::kStateChannel, url, timeout_s, url);
    exit_code() = 1;
  });
}

}  // namespace dualv::apps
