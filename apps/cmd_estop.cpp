// `dualv estop`: sends a software stop request over LCM. Accepted unsigned by
// `dualv run` (stopping must never need a key). It is not the machine's
// emergency stop: that is the hardwired circuit to the drives' STO inputs.
#include <fmt/core.h>

#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <optional>
#include <string>
#include <thread>

#include "apps/commands.hpp"
#include "runtime/channels.hpp"
#include "runtime/command_auth.hpp"
#include "runtime/command_channel.hpp"
#include "runtime/lcm_url.hpp"

namespace dualv::apps {

void register_estop_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "estop", "Send a software e-stop request to a running `dualv run` (no key needed)");
  static std::string url = runtime::kLiveUrl;
  static std::string key_file;
  static int repeat = 3;
  cmd->add_option("--lcm", url, kRobotUrlHelp)->capture_default_str();
  cmd->add_option("--key", key_file, "Sign it too (optional: e-stops are accepted unsigned)");
  cmd->add_option("--repeat", repeat, "Send it this many times, 10 ms apart (UDP may drop one)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->callback([] {
    std::optional<runtime::CommandKey> key;
    if (!key_file.empty()) key = runtime::load_command_key(key_file);
    const std::string to = runtime::command_url(url);  // runtime/lcm_url.hpp
    auto lcm = runtime::open_lcm(to);
    for (int i = 0; i < repeat; ++i) {
      if (i > 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      runtime::send_command(*lcm, runtime::CommandKind::kEstop, "", key ? &*key : nullptr);
    }
    fmt::print(
        "dualv estop: stop request sent on {} ({}x). Check it took effect with `dualv status`.\n"
        "This is a software stop; the machine's emergency stop is the hardwired STO circuit.\n",
        to, repeat);
  });
}

}  // namespace dualv::apps
