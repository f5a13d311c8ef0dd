#pragma once
// Where `dualv` finds its files. The configuration: --config FILE, else $DUALV_CONFIG, else
// dualv.yaml in the build's default config folder. Every other default (the program
// paper.yaml, the command key folder keys/, a program named in a signed start) comes from
// that same default config folder, NOT from the folder of a --config file: the folder is
// fixed when the binary is built (DUALV_CONFIG_DIR in apps/CMakeLists.txt: the source tree's
// config/ for a developer build, /etc/dualv for the installed package), and the help texts
// below print it, so `--help` says where a default really comes from (issue 14, defect 7).
//
// The replay state of signed commands (runtime/replay_state.hpp, docs/safety.md "Signed
// commands"): --replay-state FILE, else replay.state in $STATE_DIRECTORY (systemd sets it from
// the unit's StateDirectory=: /var/lib/dualv for packaging/systemd/dualv.service), else
// $XDG_STATE_HOME/dualv/replay.state, else $HOME/.local/state/dualv/replay.state (a
// development run).
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

#ifndef DUALV_DEFAULT_CONFIG_DIR
#define DUALV_DEFAULT_CONFIG_DIR "/etc/dualv"
#endif

namespace dualv::apps {

inline std::string default_config_dir() { return DUALV_DEFAULT_CONFIG_DIR; }
inline std::string default_program_file() { return default_config_dir() + "/paper.yaml"; }
inline std::string default_keys_dir() { return default_config_dir() + "/keys"; }

// The default replay state file in this environment; empty when none of $STATE_DIRECTORY,
// $XDG_STATE_HOME and $HOME is set (then --replay-state must be given).
inline std::string default_replay_state_file() {
  auto env = [](const char* name) -> std::string {
    const char* v = std::getenv(name);
    return v != nullptr ? v : "";
  };
  // systemd joins several StateDirectory= folders with ':'; the first is the unit's own.
  if (const std::string d = env("STATE_DIRECTORY"); !d.empty())
    return d.substr(0, d.find(':')) + "/replay.state";
  if (const std::string d = env("XDG_STATE_HOME"); !d.empty()) return d + "/dualv/replay.state";
  if (const std::string d = env("HOME"); !d.empty()) return d + "/.local/state/dualv/replay.state";
  return {};
}

inline std::string config_help() {
  return "Robot configuration YAML (default: $DUALV_CONFIG, else " + default_config_dir() +
         "/dualv.yaml)";
}
inline std::string program_help() {
  return "Program YAML (default: " + default_program_file() + ")";
}
inline std::string keys_help() {
  return "Folder of command keys (default: " + default_keys_dir() + ")";
}

inline std::string replay_state_help() {
  const std::string now = default_replay_state_file();
  return "Replay state of signed commands: the highest sequence accepted per key, kept across "
         "restarts (default: $STATE_DIRECTORY/replay.state under systemd, else "
         "$XDG_STATE_HOME/dualv/replay.state, else ~/.local/state/dualv/replay.state; here: " +
         (now.empty() ? std::string("none, give --replay-state") : now) + ")";
}

inline void add_config_option(CLI::App& cmd, std::string& config) {
  cmd.add_option("-c,--config", config, config_help());
}

inline std::string resolve_config(const std::string& given) {
  if (!given.empty()) return given;
  if (const char* env = std::getenv("DUALV_CONFIG"); env != nullptr && *env != '\0') return env;
  return default_config_dir() + "/dualv.yaml";
}

inline std::string resolve_program(const std::string& given) {
  return given.empty() ? default_program_file() : given;
}

inline std::string resolve_keys_dir(const std::string& given) {
  return given.empty() ? default_keys_dir() : given;
}

// Throws std::runtime_error (what to give) when there is no default.
inline std::string resolve_replay_state(const std::string& given) {
  if (!given.empty()) return given;
  std::string file = default_replay_state_file();
  if (file.empty())
    throw std::runtime_error(
        "no default replay state file ($STATE_DIRECTORY, $XDG_STATE_HOME and $HOME are unset): "
        "give --replay-state FILE");
  return file;
}

// A program named in a signed start (`dualv start NAME`): NAME as a path, else NAME or
// NAME.yaml in the default config folder.
inline std::string resolve_named_program(const std::string& name) {
  if (std::filesystem::exists(name)) return name;
  const std::string in_dir = default_config_dir() + "/" + name;
  if (std::filesystem::exists(in_dir)) return in_dir;
  return in_dir + ".yaml";
}

}  // namespace dualv::apps
