// `dualv check-target`: does this PC have what the real-time loop and the CAN
// bus need? Reports each item with what to fix; exit code 1 when something
// required is missing (2 with --strict when anything only warns).
#include <fmt/core.h>
#include <yaml-cpp/yaml.h>

#include <string>

#include "apps/commands.hpp"
#include "apps/config_path.hpp"
#include "runtime/target_check.hpp"

namespace dualv::apps {

namespace {

// Loose reading: check-target must also work on a PC whose configuration does
// not load yet (that is one of the things it helps to fix).
void read_config(const std::string& path, runtime::TargetCheckInput& in, bool iface_given,
                 bool bitrate_given) {
  try {
    const YAML::Node root = YAML::LoadFile(path);
    if (const auto loop = root["loop"]; loop && loop["priority"])
      in.priority = loop["priority"].as<int>();
    if (const auto can = root["can"]; can && can.IsMap()) {
      if (!iface_given && can["interface"]) in.can_interface = can["interface"].as<std::string>();
      if (!bitrate_given && can["bitrate"]) in.can_bitrate = can["bitrate"].as<std::int64_t>();
    }
    fmt::print("configuration: {}\n", path);
  } catch (const std::exception& e) {
    fmt::print("configuration: {} not read ({}); using defaults\n", path, e.what());
  }
}

}  // namespace

void register_check_target_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "check-target",
      "Check this PC for a real-time target: PREEMPT_RT, isolated CPUs, limits, CAN");
  static std::string config;
  static std::string iface;
  static std::int64_t bitrate = 0;
  static bool strict = false;
  add_config_option(*cmd, config);
  cmd->add_option("--iface", iface,
                  "CAN interface (default: can.interface from the config, or can0)");
  cmd->add_option("--bitrate", bitrate, "CAN bitrate, bit/s (default: can.bitrate, or 1000000)")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--strict", strict, "Also fail on warnings (no isolated CPU, vcan)");
  cmd->callback([] {
    runtime::TargetCheckInput in;
    read_config(resolve_config(config), in, !iface.empty(), bitrate > 0);
    if (!iface.empty()) in.can_interface = iface;
    if (bitrate > 0) in.can_bitrate = bitrate;
    const runtime::TargetReport report = runtime::check_target(in);
    fmt::print("{}", report.format());
    if (report.ok(strict)) {
      fmt::print("target ready{}\n", report.ok(true) ? "" : " (see warnings)");
    } else {
      fmt::print("target NOT ready: fix the FAIL items above{}\n",
                 strict ? " (and, with --strict, the WARN items)" : "");
      exit_code() = 1;
    }
  });
}

}  // namespace dualv::apps
