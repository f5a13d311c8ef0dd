// `dualv reset --key FILE`: asks a running `dualv run` to clear a latched stop.
// Signed (HMAC-SHA256 with the key file): resetting a stop can lead to motion.
// The reset does not start motion by itself; `dualv start` does.
#include <fmt/core.h>

#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

#include "apps/commands.hpp"
#include "runtime/channels.hpp"
#include "runtime/command_auth.hpp"
#include "runtime/command_channel.hpp"
#include "runtime/lcm_url.hpp"

namespace dualv::apps {

void register_reset_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("reset", "Clear a latched stop of a running `dualv run` (signed)");
  static std::string url = runtime::kLiveUrl;
  static std::string key_file;
  cmd->add_option("--lcm", url, kRobotUrlHelp)->capture_default_str();
  cmd->add_option("--key", key_file,
                  "Key file (32 bytes; its name without extension is the key id)")
      ->required();
  cmd->callback([] {
    std::vector<std::string> warnings;
    const runtime::CommandKey key = runtime::load_command_key(key_file, &warnings);
    for (const auto& w : warnings) fmt::print(stderr, "dualv reset: warning: {}\n", w);
    const std::string to = runtime::command_url(url);  // runtime/lcm_url.hpp
    auto lcm = runtime::open_lcm(to);
    const auto sent = runtime::send_command(*lcm, runtime::CommandKind::kReset, "", &key);
    fmt::print("dualv reset: sent on {} (key '{}', sequence {}). Check with `dualv status`.\n", to,
               key.id, sent.sequence);
  });
}

}  // namespace dualv::apps
