#include "runtime/command_auth.hpp"

#include <fmt/format.h>
#include <sodium.h>
#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>

#include "common/config_error.hpp"
#include "runtime/replay_state.hpp"

namespace dualv::runtime {

static_assert(crypto_auth_hmacsha256_BYTES == 32 && crypto_auth_hmacsha256_KEYBYTES == kKeyBytes);

namespace {

void init_sodium() {
  // Idempotent and thread-safe; -1 only when no entropy source exists.
  if (sodium_init() < 0) throw std::runtime_error("libsodium failed to initialise");
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Any signed LCM message (command_t, setpoint_t): its encoding with the hmac zeroed. The
// encoding starts with the type's fingerprint, so a signature never verifies for another type.
template <class Msg>
std::vector<unsigned char> signing_payload(const Msg& msg) {
  Msg unsigned_copy = msg;
  std::fill(std::begin(unsigned_copy.hmac), std::end(unsigned_copy.hmac), 0);
  std::vector<unsigned char> buf(static_cast<std::size_t>(unsigned_copy.getEncodedSize()));
  unsigned_copy.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

template <class Msg>
void sign_message(Msg& msg, const CommandKey& key) {
  init_sodium();
  msg.key_id = key.id;
  const std::vector<unsigned char> payload = signing_payload(msg);
  crypto_auth_hmacsha256(reinterpret_cast<unsigned char*>(msg.hmac), payload.data(), payload.size(),
                         key.bytes.data());
}

// Decodes an LCM payload that must be exactly one canonical `Msg`; else false and why.
template <class Msg>
bool decode_canonical(const void* data, std::size_t size, Msg& out, std::string& reason) {
  int used = -1;
  try {
    // lcm-gen's decoders are post-processed to refuse a string length <= 0
    // (lcm/harden_decoders.cmake); anything else they throw is a malformed message too.
    if (size <= 1'000'000) used = out.decode(data, 0, static_cast<int>(size));
  } catch (const std::exception&) {
    used = -1;
  }
  if (used < 0 || static_cast<std::size_t>(used) != size) {
    reason = used < 0 ? fmt::format("{} bytes that do not decode as {}", size, Msg::getTypeName())
                      : fmt::format("{} trailing bytes after {}", size - used, Msg::getTypeName());
    return false;
  }
  // The signature covers the canonical encoding. lcm-gen's decoder ignores
  // the NUL terminator bytes of strings, so bytes that differ from the
  // canonical encoding would otherwise still verify: refuse them.
  std::vector<unsigned char> canonical(size);
  out.encode(canonical.data(), 0, static_cast<int>(size));
  if (std::memcmp(canonical.data(), data, size) != 0) {
    reason = "non-canonical encoding (a string terminator was altered)";
    return false;
  }
  return true;
}

bool all_zero(const std::uint8_t* p, std::size_t n) {
  // Constant-time (sodium_is_zero): no timing hint about the signature.
  return sodium_is_zero(p, n) == 1;
}

bool printable(const std::string& s) {
  return std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isprint(c) != 0; });
}

}  // namespace

const char* to_string(CommandKind kind) noexcept {
  switch (kind) {
    case CommandKind::kStartProgram:
      return "start";
    case CommandKind::kStop:
      return "stop";
    case CommandKind::kEstop:
      return "estop";
    case CommandKind::kReset:
      return "reset";
  }
  return "unknown";
}

const char* to_string(CommandVerdict v) noexcept {
  switch (v) {
    case CommandVerdict::kAccepted:
      return "accepted";
    case CommandVerdict::kMalformed:
      return "malformed";
    case CommandVerdict::kUnsigned:
      return "unsigned";
    case CommandVerdict::kUnknownKey:
      return "unknown key";
    case CommandVerdict::kBadSignature:
      return "bad signature";
    case CommandVerdict::kStale:
      return "stale";
    case CommandVerdict::kReplayed:
      return "replayed";
  }
  return "unknown";
}

CommandKey load_command_key(const std::string& path, std::vector<std::string>* warnings) {
  init_sodium();
  const std::string create_hint =
      fmt::format("create one with: head -c 32 /dev/urandom > {0} && chmod 600 {0}", path);
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw ConfigError(
        {fmt::format("key file {}: {}; {}", path, std::strerror(errno), create_hint)});
  if (!S_ISREG(st.st_mode))
    throw ConfigError({fmt::format("key file {}: not a regular file", path)});
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw ConfigError({fmt::format("key file {}: cannot open ({})", path, std::strerror(errno))});
  std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());

  CommandKey key;
  key.id = std::filesystem::path(path).stem().string();
  if (content.size() == kKeyBytes) {
    std::memcpy(key.bytes.data(), content.data(), kKeyBytes);
  } else {
    std::string hex = content;
    hex.erase(std::remove_if(hex.begin(), hex.end(),
                             [](unsigned char c) { return std::isspace(c) != 0; }),
              hex.end());
    bool ok = hex.size() == 2 * kKeyBytes;
    for (std::size_t i = 0; ok && i < kKeyBytes; ++i) {
      const int hi = hex_value(hex[2 * i]);
      const int lo = hex_value(hex[2 * i + 1]);
      ok = hi >= 0 && lo >= 0;
      if (ok) key.bytes[i] = static_cast<unsigned char>(hi * 16 + lo);
    }
    if (!ok)
      throw ConfigError({fmt::format(
          "key file {}: must hold exactly 32 bytes, raw or as 64 hex digits (got {} bytes); {}",
          path, content.size(), create_hint)});
  }
  if (sodium_is_zero(key.bytes.data(), key.bytes.size()) == 1)
    throw ConfigError({fmt::format("key file {}: the key is all zeros; {}", path, create_hint)});
  if (key.id.empty()) throw ConfigError({fmt::format("key file {}: name gives no key id", path)});
  if (warnings != nullptr && (st.st_mode & (S_IROTH | S_IWOTH)) != 0)
    warnings->push_back(fmt::format(
        "key file {} is {} by every user (mode {:04o}): anyone on this machine can sign "
        "commands that move the robot; run: chmod 600 {}",
        path, (st.st_mode & S_IWOTH) != 0 ? "writable" : "readable", st.st_mode & 07777, path));
  return key;
}

std::vector<CommandKey> load_command_keys(const std::string& dir,
                                          std::vector<std::string>* warnings) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw ConfigError(
        {fmt::format("command key folder {}: not a folder; create it (mkdir -m 750 {}) and put one "
                     "<operator>.key per operator in it",
                     dir, dir)});
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (entry.is_regular_file() && entry.path().extension() == ".key")
      files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());  // deterministic order, independent of the file system
  std::vector<CommandKey> keys;
  for (const auto& f : files) keys.push_back(load_command_key(f, warnings));
  if (keys.empty() && warnings != nullptr)
    warnings->push_back(fmt::format(
        "no command keys in {}: only e-stops will be accepted (start and reset need a key)", dir));
  return keys;
}

void sign_command(dualv_lcm::command_t& cmd, const CommandKey& key) { sign_message(cmd, key); }

void sign_setpoint(dualv_lcm::setpoint_t& setpoint, const CommandKey& key) {
  sign_message(setpoint, key);
}

dualv_lcm::setpoint_t make_setpoint(double x, double y, double theta, std::int64_t utime,
                                    std::int64_t sequence, const CommandKey* key) {
  dualv_lcm::setpoint_t sp;
  sp.utime = utime;
  sp.sequence = sequence;
  sp.x = x;
  sp.y = y;
  sp.theta = theta;
  sp.key_id = "";
  std::fill(std::begin(sp.hmac), std::end(sp.hmac), 0);
  if (key != nullptr) sign_message(sp, *key);
  return sp;
}

dualv_lcm::command_t make_command(CommandKind kind, const std::string& program, std::int64_t utime,
                                  std::int64_t sequence, const CommandKey* key) {
  dualv_lcm::command_t cmd;
  cmd.utime = utime;
  cmd.sequence = sequence;
  cmd.kind = static_cast<std::int8_t>(kind);
  cmd.program = program;
  cmd.key_id = "";
  std::fill(std::begin(cmd.hmac), std::end(cmd.hmac), 0);
  if (key != nullptr) sign_command(cmd, *key);
  return cmd;
}

CommandVerifier::CommandVerifier(std::vector<CommandKey> keys, CommandAuthConfig config)
    : keys_(std::move(keys)), config_(config) {
  init_sodium();
  for (std::size_t i = 0; i < keys_.size(); ++i)
    for (std::size_t j = i + 1; j < keys_.size(); ++j)
      if (keys_[i].id == keys_[j].id)
        throw ConfigError({fmt::format("two command keys have the id '{}'", keys_[i].id)});
  if (config_.replay_state_file.empty()) return;
  LoadedReplayState st = load_replay_state(config_.replay_state_file);
  if (st.status == ReplayStateStatus::kLoaded) {
    last_sequence_ = std::move(st.marks.commands);
    last_setpoint_sequence_ = std::move(st.marks.setpoints);
    state_note_ = st.message;
  } else {
    floor_pending_ = true;
    state_note_ = fmt::format(
        "{}; signed messages sent up to {:.1f} s after the first one received are refused as "
        "possible replays (state lost), and a new file is written on the next accepted one",
        st.message, static_cast<double>(config_.max_future_us) * 1e-6);
  }
}

void CommandVerifier::arm_floor(std::int64_t now_utime) {
  if (!floor_pending_) return;
  floor_pending_ = false;
  floor_utime_ =
      now_utime > INT64_MAX - config_.max_future_us ? INT64_MAX : now_utime + config_.max_future_us;
}

void CommandVerifier::persist(bool setpoint, std::int64_t now_utime, std::string& reason) {
  if (config_.replay_state_file.empty()) return;
  if (setpoint && last_setpoint_save_ != INT64_MIN && now_utime >= last_setpoint_save_ &&
      now_utime - last_setpoint_save_ < 100'000)
    return;
  if (setpoint) last_setpoint_save_ = now_utime;
  const std::string err =
      save_replay_state(config_.replay_state_file, {last_sequence_, last_setpoint_sequence_});
  if (!err.empty()) {
    ++save_failures_;
    last_save_error_ = err;
    reason += fmt::format(" (replay state NOT saved: {})", err);
  }
}

std::uint64_t CommandVerifier::refused() const noexcept {
  std::uint64_t n = 0;
  for (int i = 1; i < kVerdictCount; ++i) n += counts_[i];
  return n;
}

VerifyResult CommandVerifier::finish(VerifyResult r) {
  ++counts_[static_cast<int>(r.verdict)];
  return r;
}

VerifyResult CommandVerifier::verify_encoded(const void* data, std::size_t size,
                                             std::int64_t now_utime) {
  VerifyResult r;
  if (!decode_canonical(data, size, r.command, r.reason)) {
    r.verdict = CommandVerdict::kMalformed;
    return finish(std::move(r));
  }
  return verify(r.command, now_utime);
}

CommandVerdict CommandVerifier::check_signed(const std::string& key_id, const std::uint8_t* hmac,
                                             const std::vector<unsigned char>& payload,
                                             std::int64_t utime, std::int64_t sequence,
                                             std::int64_t now_utime, std::int64_t max_age_us,
                                             std::map<std::string, std::int64_t>& last_sequence,
                                             const char* what, std::string& reason) const {
  if (all_zero(hmac, 32)) {
    reason = fmt::format("{} needs a signature (use --key)", what);
    return CommandVerdict::kUnsigned;
  }
  const auto key = std::find_if(keys_.begin(), keys_.end(),
                                [&](const CommandKey& kk) { return kk.id == key_id; });
  if (key == keys_.end()) {
    reason = fmt::format("no key with id '{}'", key_id);
    return CommandVerdict::kUnknownKey;
  }
  if (crypto_auth_hmacsha256_verify(hmac, payload.data(), payload.size(), key->bytes.data()) != 0) {
    reason = fmt::format("signature does not match key '{}'", key_id);
    return CommandVerdict::kBadSignature;
  }
  // Time and sequence only after the signature: an unauthenticated message
  // must not be able to advance the replay window.
  // utime is the sender's, any int64 (fuzz/command_verifier found the overflow): the age
  // saturates instead of overflowing.
  std::int64_t age = 0;
  if (__builtin_sub_overflow(now_utime, utime, &age))
    age = utime < 0 ? std::numeric_limits<std::int64_t>::max()
                    : std::numeric_limits<std::int64_t>::min();
  if (age > max_age_us || age < -config_.max_future_us) {
    reason = fmt::format(
        "sent {:.3f} s {} (accepted: up to {:.3f} s old, {:.3f} s ahead): "
        "check both clocks (NTP)",
        std::abs(static_cast<double>(age)) * 1e-6, age < 0 ? "in the future" : "ago",
        static_cast<double>(max_age_us) * 1e-6, static_cast<double>(config_.max_future_us) * 1e-6);
    return CommandVerdict::kStale;
  }
  if (utime <= floor_utime_) {
    reason = fmt::format(
        "sent before {:.3f} s after the replay state was found lost: possibly a replay from "
        "before the restart; send it again",
        static_cast<double>(config_.max_future_us) * 1e-6);
    return CommandVerdict::kReplayed;
  }
  auto last = last_sequence.find(key_id);
  if (last != last_sequence.end() && sequence <= last->second) {
    reason = fmt::format("sequence {} not above {} for key '{}'", sequence, last->second, key_id);
    return CommandVerdict::kReplayed;
  }
  last_sequence[key_id] = sequence;
  reason = fmt::format("{} signed by '{}'", what, key_id);
  return CommandVerdict::kAccepted;
}

SetpointVerifyResult CommandVerifier::verify_setpoint_encoded(const void* data, std::size_t size,
                                                              std::int64_t now_utime) {
  SetpointVerifyResult r;
  if (!decode_canonical(data, size, r.setpoint, r.reason)) {
    r.verdict = CommandVerdict::kMalformed;
    ++setpoint_counts_[static_cast<int>(r.verdict)];
    return r;
  }
  return verify_setpoint(r.setpoint, now_utime);
}

SetpointVerifyResult CommandVerifier::verify_setpoint(const dualv_lcm::setpoint_t& sp,
                                                      std::int64_t now_utime) {
  SetpointVerifyResult r;
  r.setpoint = sp;
  if (sp.key_id.size() > 64 || !printable(sp.key_id)) {
    r.verdict = CommandVerdict::kMalformed;
    r.reason = "key id too long or not printable";
  } else if (!std::isfinite(sp.x) || !std::isfinite(sp.y) || !std::isfinite(sp.theta)) {
    r.verdict = CommandVerdict::kMalformed;
    r.reason = fmt::format("pose ({}, {}, {}) is not finite", sp.x, sp.y, sp.theta);
  } else {
    arm_floor(now_utime);
    r.verdict =
        check_signed(sp.key_id, sp.hmac, signing_payload(sp), sp.utime, sp.sequence, now_utime,
                     config_.max_setpoint_age_us, last_setpoint_sequence_, "setpoint", r.reason);
    if (r.verdict == CommandVerdict::kAccepted) persist(true, now_utime, r.reason);
  }
  ++setpoint_counts_[static_cast<int>(r.verdict)];
  return r;
}

VerifyResult CommandVerifier::verify(const dualv_lcm::command_t& cmd, std::int64_t now_utime) {
  VerifyResult r;
  r.command = cmd;
  auto refuse = [&](CommandVerdict v, std::string why) {
    r.verdict = v;
    r.reason = std::move(why);
    return finish(std::move(r));
  };

  const int k = cmd.kind;
  if (k < dualv_lcm::command_t::KIND_START_PROGRAM || k > dualv_lcm::command_t::KIND_RESET)
    return refuse(CommandVerdict::kMalformed, fmt::format("unknown command kind {}", k));
  const auto kind = static_cast<CommandKind>(cmd.kind);
  if (cmd.program.size() > config_.max_program_name || !printable(cmd.program) ||
      cmd.key_id.size() > 64 || !printable(cmd.key_id))
    return refuse(CommandVerdict::kMalformed, "program name or key id too long or not printable");
  if (kind == CommandKind::kStartProgram && cmd.program.empty())
    return refuse(CommandVerdict::kMalformed, "start without a program name");

  if (kind == CommandKind::kEstop) {
    r.verdict = CommandVerdict::kAccepted;
    r.reason = "e-stop (accepted signed or not)";
    return finish(std::move(r));
  }

  arm_floor(now_utime);
  r.verdict =
      check_signed(cmd.key_id, cmd.hmac, signing_payload(cmd), cmd.utime, cmd.sequence, now_utime,
                   config_.max_age_us, last_sequence_, to_string(kind), r.reason);
  if (r.verdict == CommandVerdict::kAccepted) persist(false, now_utime, r.reason);
  return finish(std::move(r));
}

}  // namespace dualv::runtime
