#pragma once
// The replay high-water marks of signed messages, kept across restarts (issue 14, defect 5;
// docs/safety.md "Signed commands"). Per key id: the highest sequence accepted for commands
// (command_t) and for setpoints (setpoint_t). Saved atomically: written to "<path>.tmp",
// fsync'ed, renamed over <path>, the folder fsync'ed, so a crash leaves the old file or the
// new one, never a torn one. Set-up and command-channel code (not the real-time loop).
//
// Format (text): "dualv-replay-state 1", then one line per mark "command <key hex> <seq>" or
// "setpoint <key hex> <seq>" (the key id in hex: any printable id survives), then
// "end <number of marks>": a file cut short or edited is detected as corrupt.
//
// Where the file lives: `dualv run --replay-state FILE` (apps/config_path.hpp has the default:
// /var/lib/dualv/replay.state for the packaged service, created empty by packaging/postinst at
// the first install).
#include <cstdint>
#include <map>
#include <string>

namespace dualv::runtime {

struct ReplayMarks {
  std::map<std::string, std::int64_t> commands;   // key id -> highest accepted sequence
  std::map<std::string, std::int64_t> setpoints;  // the same, for setpoint_t
};

enum class ReplayStateStatus { kLoaded, kMissing, kCorrupt };

struct LoadedReplayState {
  ReplayStateStatus status = ReplayStateStatus::kMissing;
  ReplayMarks marks;    // empty unless kLoaded
  std::string message;  // what was found, for the log ("... missing: ...")
};

LoadedReplayState load_replay_state(const std::string& path);
// Returns an empty string on success, else why it failed (the old file is left in place).
std::string save_replay_state(const std::string& path, const ReplayMarks& marks);

// A first use: when the folder of `path` does not exist yet, nothing was ever accepted there,
// so the folder (0700) and an empty state are created; returns what was done, for the log.
// When the folder exists, does nothing and returns "": a missing file there is a lost state
// (CommandAuthConfig::replay_state_file). Throws std::runtime_error naming the path and the
// reason when the folder or the file cannot be created.
std::string create_replay_state_on_first_use(const std::string& path);

}  // namespace dualv::runtime
