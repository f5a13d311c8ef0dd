// `dualv start PROGRAM --key FILE`: asks a running `dualv run` to start a
// program. Signed (HMAC-SHA256): it moves the robot. The robot first moves
// from its actual pose to the program's start; the receiver refuses unsigned,
// stale or replayed requests.
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

void register_start_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("start", "Start a program on a running `dualv run` (signed)");
  static std::string url = runtime::kLiveUrl;
  static std::string key_file;
  static std::string program;
  cmd->add_option("program", program,
                  "Program name, as `dualv run` knows it; `stream`: follow `dualv stream`")
      ->required();
  cmd->add_option("--lcm", url, kRobotUrlHelp)->capture_default_str();
  cmd->add_option("--key", key_file,
                  "Key file (32 bytes; its name without extension is the key id)")
      ->required();
  cmd->callback([] {
    if (program.size() > 64) {
      fmt::print(stderr, "dualv start: program name longer than 64 characters\n");
      exit_code() = 2;
      return;
    }
    std::vector<std::string> warnings;
    const runtime::CommandKey key = runtime::load_command_key(key_file, &warnings);
    for (const auto& w : warnings) fmt::print(stderr, "dualv start: warning: {}\n", w);
    const std::string to = runtime::command_url(url);  // runtime/lcm_url.hpp
    auto lcm = runtime::open_lcm(to);
    const auto sent =
        runtime::send_command(*lcm, runtime::CommandKind::kStartProgram, program, &key);
    fmt::print(
        "dualv start: '{}' requested on {} (key '{}', sequence {}). Follow it with "
        "`dualv status --follow`.\n",
        program, to, key.id, sent.sequence);
  });
}

}  // namespace dualv::apps
