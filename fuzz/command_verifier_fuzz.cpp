// The command and setpoint verifier (runtime/command_auth.hpp) on what arrives on the LCM
// channels DUALV_COMMAND / DUALV_SETPOINT: raw bytes (decode, then verify), and messages built
// from the input and signed with the verifier's key (or another), optionally with one byte of
// the encoding altered, so the checks behind the signature are reached too. Each signed
// message's verdict is predicted from the rules of lcm/command_t.lcm and lcm/setpoint_t.lcm
// (an independent oracle with its own replay memory) and must match; an altered message is
// never accepted, except an e-stop (accepted from anyone).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include <fuzzer/FuzzedDataProvider.h>

#include "runtime/command_auth.hpp"

#include "fuzz/check.hpp"

namespace rt = dualv::runtime;
using rt::CommandVerdict;

namespace {

constexpr std::int64_t kNow = 1'764'590'000'000'000;  // us since 1970 (2025-12-01)

rt::CommandKey key(const char* id, unsigned char fill) {
  rt::CommandKey k;
  k.id = id;
  k.bytes.fill(fill);
  k.bytes[0] = 0x5A;
  return k;
}

bool printable(const std::string& s) {
  return std::all_of(s.begin(), s.end(), [](unsigned char c) { return c >= 0x20 && c < 0x7F; });
}

// The verdict lcm/*.lcm and runtime/command_auth.hpp promise for a correctly signed (or
// unsigned) message, before any byte is altered.
struct Oracle {
  rt::CommandAuthConfig cfg;
  std::map<std::string, std::int64_t> last_command, last_setpoint;
  CommandVerdict signed_checks(bool is_signed, bool known_key, const std::string& key_id,
                               std::int64_t utime, std::int64_t sequence, std::int64_t max_age,
                               std::map<std::string, std::int64_t>& last) const {
    if (!is_signed) return CommandVerdict::kUnsigned;
    if (!known_key) return CommandVerdict::kUnknownKey;
    const __int128 age = static_cast<__int128>(kNow) - utime;  // no overflow here
    if (age > max_age || -age > cfg.max_future_us) return CommandVerdict::kStale;
    if (const auto it = last.find(key_id); it != last.end() && sequence <= it->second)
      return CommandVerdict::kReplayed;
    last[key_id] = sequence;
    return CommandVerdict::kAccepted;
  }
};

std::vector<unsigned char> encode(auto& msg) {
  std::vector<unsigned char> b(static_cast<std::size_t>(msg.getEncodedSize()));
  FUZZ_CHECK(msg.encode(b.data(), 0, static_cast<int>(b.size())) == static_cast<int>(b.size()));
  return b;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  static const rt::CommandKey operator_key = key("operator", 0x11);
  static const rt::CommandKey stranger_key = key("stranger", 0x22);  // not in the verifier
  rt::CommandVerifier verifier({operator_key});
  Oracle oracle;

  while (in.remaining_bytes() > 0) {
    const std::uint8_t op = in.ConsumeIntegral<std::uint8_t>();
    if ((op & 3u) == 0) {  // raw bytes off the wire
      const std::string raw = in.ConsumeRandomLengthString(256);
      // Nobody here holds the key, so raw bytes are accepted only as an e-stop or as a
      // verbatim copy of a message signed earlier in this input; the oracle follows the
      // replay memory in that (unlikely) case.
      if ((op & 4u) == 0) {
        const auto r = verifier.verify_encoded(raw.data(), raw.size(), kNow);
        if (r.verdict == CommandVerdict::kAccepted &&
            r.command.kind != dualv_lcm::command_t::KIND_ESTOP)
          oracle.last_command[r.command.key_id] = r.command.sequence;
      } else {
        const auto r = verifier.verify_setpoint_encoded(raw.data(), raw.size(), kNow);
        if (r.verdict == CommandVerdict::kAccepted)
          oracle.last_setpoint[r.setpoint.key_id] = r.setpoint.sequence;
      }
      continue;
    }
    const bool is_signed = (op & 8u) == 0;
    const bool known_key = (op & 16u) == 0;
    const bool alter = (op & 32u) != 0;
    const rt::CommandKey& k = known_key ? operator_key : stranger_key;
    const std::int64_t utime =
        (op & 64u) == 0 ? kNow - in.ConsumeIntegralInRange<std::int64_t>(-1'500'000, 3'000'000)
                        : in.ConsumeIntegral<std::int64_t>();
    const std::int64_t sequence = in.ConsumeIntegral<std::int64_t>();
    const Oracle before = oracle;  // an altered message must leave the replay memory alone
    std::vector<unsigned char> bytes;
    const bool is_setpoint = (op & 3u) == 3u;
    CommandVerdict expected = CommandVerdict::kMalformed;
    std::int8_t kind = 0;
    if (is_setpoint) {
      const double x = (op & 128u) != 0 ? std::nan("") : in.ConsumeFloatingPoint<double>();
      const double y = in.ConsumeProbability<double>() - 0.5;
      const double theta = in.ConsumeFloatingPoint<double>();
      dualv_lcm::setpoint_t sp =
          rt::make_setpoint(x, y, theta, utime, sequence, is_signed ? &k : nullptr);
      if (!is_signed) sp.key_id = k.id;
      bytes = encode(sp);
      if (std::isfinite(x) && std::isfinite(y) && std::isfinite(theta))
        expected = oracle.signed_checks(is_signed, known_key, k.id, utime, sequence,
                                        oracle.cfg.max_setpoint_age_us, oracle.last_setpoint);
    } else {
      kind = static_cast<std::int8_t>(in.ConsumeIntegralInRange<int>(0, 5));
      // LCM strings are C strings (lcm-gen encodes up to the first NUL): none inside.
      std::string program = in.ConsumeRandomLengthString(80);
      program.erase(std::remove(program.begin(), program.end(), '\0'), program.end());
      dualv_lcm::command_t cmd;
      cmd.utime = utime;
      cmd.sequence = sequence;
      cmd.kind = kind;
      cmd.program = program;
      cmd.key_id = k.id;
      std::fill(std::begin(cmd.hmac), std::end(cmd.hmac), 0);
      if (is_signed) rt::sign_command(cmd, k);
      bytes = encode(cmd);
      if (kind < 1 || kind > 4 || program.size() > oracle.cfg.max_program_name ||
          !printable(program) || (kind == 1 && program.empty()))
        expected = CommandVerdict::kMalformed;
      else if (kind == 3)
        expected = CommandVerdict::kAccepted;  // e-stop: from anyone
      else
        expected = oracle.signed_checks(is_signed, known_key, k.id, utime, sequence,
                                        oracle.cfg.max_age_us, oracle.last_command);
    }
    if (alter && !bytes.empty()) {
      const std::size_t at = in.ConsumeIntegralInRange<std::size_t>(0, bytes.size() - 1);
      const auto x = static_cast<unsigned char>(in.ConsumeIntegralInRange<int>(1, 255));
      bytes[at] ^= x;
      if (is_setpoint) {
        const auto r = verifier.verify_setpoint_encoded(bytes.data(), bytes.size(), kNow);
        FUZZ_CHECK(r.verdict != CommandVerdict::kAccepted);
      } else {
        const auto r = verifier.verify_encoded(bytes.data(), bytes.size(), kNow);
        FUZZ_CHECK(r.verdict != CommandVerdict::kAccepted ||
                   r.command.kind == dualv_lcm::command_t::KIND_ESTOP);
      }
      oracle = before;  // nothing signed was accepted
      continue;
    }
    std::string reason;
    CommandVerdict got;
    if (is_setpoint) {
      const auto r = verifier.verify_setpoint_encoded(bytes.data(), bytes.size(), kNow);
      got = r.verdict;
      reason = r.reason;
    } else {
      const auto r = verifier.verify_encoded(bytes.data(), bytes.size(), kNow);
      got = r.verdict;
      reason = r.reason;
    }
    if (got != expected)
      std::fprintf(stderr, "verdict %s (%s), the oracle says %s\n", rt::to_string(got),
                   reason.c_str(), rt::to_string(expected));
    FUZZ_CHECK(got == expected);
  }
  return 0;
}
