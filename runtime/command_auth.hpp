#pragma once
// Authentication of operator commands (dualv_lcm::command_t) and of streamed pose setpoints
// (dualv_lcm::setpoint_t): both are signed and checked the same way, by the same code.
//
// Commands that start motion or reset a stop carry
//   hmac = HMAC-SHA256(key, LCM encoding of the command with hmac zeroed)
// (libsodium crypto_auth_hmacsha256; verification is constant-time). The
// verifier refuses a command that is malformed, unsigned, signed with an
// unknown key or a wrong signature, stale (sender time outside the window)
// or replayed (sequence not above the last accepted one for its key). An
// e-stop is accepted in every one of those cases but malformed: stopping
// must never depend on holding a key, and a replayed stop is harmless.
//
// Key files hold 32 bytes, raw or as 64 hex digits; the key id is the file
// name without extension (/etc/dualv/keys/operator.key -> "operator").
// Create one with: head -c 32 /dev/urandom > operator.key && chmod 600 operator.key
#include <array>
#include <climits>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "dualv_lcm/command_t.hpp"
#include "dualv_lcm/setpoint_t.hpp"

namespace dualv::runtime {

inline constexpr std::size_t kKeyBytes = 32;

enum class CommandKind : std::int8_t {
  kStartProgram = dualv_lcm::command_t::KIND_START_PROGRAM,
  kStop = dualv_lcm::command_t::KIND_STOP,
  kEstop = dualv_lcm::command_t::KIND_ESTOP,
  kReset = dualv_lcm::command_t::KIND_RESET,
};
const char* to_string(CommandKind kind) noexcept;

struct CommandKey {
  std::string id;
  std::array<unsigned char, kKeyBytes> bytes{};
};

// Loads a key file. Throws dualv::ConfigError naming the file and the fix when
// it is missing, unreadable, of the wrong size or all zeros. Appends a warning
// to `warnings` (when given) if the file is readable or writable by others.
CommandKey load_command_key(const std::string& path, std::vector<std::string>* warnings = nullptr);

// Loads every *.key file in `dir` (the receiver's key ring, e.g.
// /etc/dualv/keys). A missing folder is a ConfigError; an empty one yields no
// keys (then only e-stops are accepted) and a warning.
std::vector<CommandKey> load_command_keys(const std::string& dir,
                                          std::vector<std::string>* warnings = nullptr);

// Builds a command (utime and sequence supplied by the caller) and signs it
// when `key` is given; unsigned commands carry an all-zero hmac.
dualv_lcm::command_t make_command(CommandKind kind, const std::string& program, std::int64_t utime,
                                  std::int64_t sequence, const CommandKey* key);
// Sets key_id and hmac of `cmd` for `key`.
void sign_command(dualv_lcm::command_t& cmd, const CommandKey& key);

// A pose setpoint, signed when `key` is given (an unsigned one is always refused).
dualv_lcm::setpoint_t make_setpoint(double x, double y, double theta, std::int64_t utime,
                                    std::int64_t sequence, const CommandKey* key);
void sign_setpoint(dualv_lcm::setpoint_t& setpoint, const CommandKey& key);

enum class CommandVerdict {
  kAccepted,
  kMalformed,     // does not decode, trailing bytes, unknown kind, bad field
  kUnsigned,      // all-zero hmac on a command that needs a signature
  kUnknownKey,    // key_id not among the verifier's keys
  kBadSignature,  // hmac does not match (wrong key, altered message)
  kStale,         // utime too old or too far in the future
  kReplayed,      // sequence not above the last accepted for this key
};
inline constexpr int kVerdictCount = 7;
const char* to_string(CommandVerdict v) noexcept;

struct CommandAuthConfig {
  std::int64_t max_age_us = 2'000'000;     // older than this: stale
  std::int64_t max_future_us = 1'000'000;  // sender clock ahead by more: stale
  std::size_t max_program_name = 64;
  // Setpoints: a stream is live data, so a tighter age window (a setpoint delayed this long
  // is no longer what the operator asks for; the stream watchdog is tighter still).
  std::int64_t max_setpoint_age_us = 500'000;
  // Where the replay high-water marks persist (runtime/replay_state.hpp, docs/safety.md), so
  // a signed message cannot be replayed after the service restarts. Empty: in memory only
  // (tests, one-shot tools). A missing or corrupt file is safe: every signed message sent
  // up to max_future_us after the first one received is refused (all a restart could
  // replay), and state_note() says so.
  std::string replay_state_file;
};

struct VerifyResult {
  CommandVerdict verdict = CommandVerdict::kMalformed;
  dualv_lcm::command_t command;  // decoded (when not malformed)
  std::string reason;            // one line for the log
};

struct SetpointVerifyResult {
  CommandVerdict verdict = CommandVerdict::kMalformed;
  dualv_lcm::setpoint_t setpoint;  // decoded (when not malformed)
  std::string reason;
};

class CommandVerifier {
 public:
  explicit CommandVerifier(std::vector<CommandKey> keys, CommandAuthConfig config = {});

  // Checks a decoded command against the clock `now_utime` (us since 1970);
  // an accepted signed command advances its key's sequence.
  VerifyResult verify(const dualv_lcm::command_t& cmd, std::int64_t now_utime);
  // Decodes an LCM payload first: anything that does not decode exactly is malformed.
  VerifyResult verify_encoded(const void* data, std::size_t size, std::int64_t now_utime);

  // Setpoints: the same checks (a non-finite pose is malformed); their sequence numbers are
  // their own (per key), apart from the commands' (a stream and a `dualv stop` from another
  // process must not refuse each other as replays).
  SetpointVerifyResult verify_setpoint(const dualv_lcm::setpoint_t& setpoint,
                                       std::int64_t now_utime);
  SetpointVerifyResult verify_setpoint_encoded(const void* data, std::size_t size,
                                               std::int64_t now_utime);

  std::uint64_t count(CommandVerdict v) const noexcept { return counts_[static_cast<int>(v)]; }
  std::uint64_t refused() const noexcept;
  std::uint64_t setpoint_count(CommandVerdict v) const noexcept {
    return setpoint_counts_[static_cast<int>(v)];
  }
  std::size_t key_count() const noexcept { return keys_.size(); }
  // What the replay state file held at construction (empty without one), for the log.
  const std::string& state_note() const noexcept { return state_note_; }
  // Accepted messages whose mark could not be saved (the last reason in last_save_error()).
  std::uint64_t state_save_failures() const noexcept { return save_failures_; }
  const std::string& last_save_error() const noexcept { return last_save_error_; }

 private:
  VerifyResult finish(VerifyResult r);
  // Before the first check after a lost state: every message sent up to now + max_future_us
  // could be a replay from before the restart.
  void arm_floor(std::int64_t now_utime);
  // Saves the marks after an accepted signed message (setpoints at most every 0.1 s);
  // appends a failure to `reason`.
  void persist(bool setpoint, std::int64_t now_utime, std::string& reason);
  // The checks every signed message shares, in this order: signed, known key, HMAC, age,
  // sequence above `last_sequence[key_id]` (advanced when accepted). `what` names the
  // message in the reason.
  CommandVerdict check_signed(const std::string& key_id, const std::uint8_t* hmac,
                              const std::vector<unsigned char>& payload, std::int64_t utime,
                              std::int64_t sequence, std::int64_t now_utime,
                              std::int64_t max_age_us,
                              std::map<std::string, std::int64_t>& last_sequence, const char* what,
                              std::string& reason) const;
  std::vector<CommandKey> keys_;
  CommandAuthConfig config_;
  std::map<std::string, std::int64_t> last_sequence_;
  std::map<std::string, std::int64_t> last_setpoint_sequence_;
  std::array<std::uint64_t, kVerdictCount> counts_{};
  std::array<std::uint64_t, kVerdictCount> setpoint_counts_{};
  std::string state_note_;
  bool floor_pending_ = false;
  std::int64_t floor_utime_ = INT64_MIN;  // signed messages sent at or before it: replayed
  std::int64_t last_setpoint_save_ = INT64_MIN;
  std::uint64_t save_failures_ = 0;
  std::string last_save_error_;
};

}  // namespace dualv::runtime
