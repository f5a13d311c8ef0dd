#include "runtime/command_auth.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "common/config_error.hpp"

namespace dualv::runtime {
namespace {

constexpr std::int64_t kNow = 1'750'000'000'000'000;  // us since 1970

CommandKey key(const std::string& id, unsigned char fill) {
  CommandKey k;
  k.id = id;
  for (std::size_t i = 0; i < kKeyBytes; ++i) k.bytes[i] = static_cast<unsigned char>(fill + i);
  return k;
}

std::vector<unsigned char> encode(const dualv_lcm::command_t& c) {
  std::vector<unsigned char> b(static_cast<std::size_t>(c.getEncodedSize()));
  c.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

class CommandAuth : public ::testing::Test {
 protected:
  CommandKey op_ = key("operator", 1);
  CommandKey lab_ = key("lab", 77);
  CommandVerifier verifier_{{op_, lab_}};
  dualv_lcm::command_t signed_cmd(CommandKind kind, std::int64_t seq, std::int64_t utime = kNow,
                                  const std::string& program = "") {
    return make_command(kind, program, utime, seq, &op_);
  }
};

TEST_F(CommandAuth, SignedStartAndResetAreAccepted) {
  auto r = verifier_.verify(signed_cmd(CommandKind::kStartProgram, 1, kNow, "paper"), kNow);
  EXPECT_EQ(r.verdict, CommandVerdict::kAccepted) << r.reason;
  EXPECT_EQ(r.command.program, "paper");
  EXPECT_EQ(verifier_.verify(signed_cmd(CommandKind::kReset, 2), kNow).verdict,
            CommandVerdict::kAccepted);
  EXPECT_EQ(verifier_.count(CommandVerdict::kAccepted), 2u);
  EXPECT_EQ(verifier_.refused(), 0u);
}

TEST_F(CommandAuth, ReplayIsRefusedAndDoesNotMoveTheWindow) {
  const auto cmd = signed_cmd(CommandKind::kReset, 10);
  EXPECT_EQ(verifier_.verify(cmd, kNow).verdict, CommandVerdict::kAccepted);
  EXPECT_EQ(verifier_.verify(cmd, kNow).verdict, CommandVerdict::kReplayed);
  EXPECT_EQ(verifier_.verify(signed_cmd(CommandKind::kReset, 9), kNow).verdict,
            CommandVerdict::kReplayed);
  EXPECT_EQ(verifier_.verify(signed_cmd(CommandKind::kReset, 11), kNow).verdict,
            CommandVerdict::kAccepted);
  EXPECT_EQ(verifier_.count(CommandVerdict::kReplayed), 2u);
}

TEST_F(CommandAuth, SequencesArePerKey) {
  EXPECT_EQ(verifier_.verify(signed_cmd(CommandKind::kReset, 100), kNow).verdict,
            CommandVerdict::kAccepted);
  // Another operator's lower sequence is independent.
  EXPECT_EQ(verifier_.verify(make_command(CommandKind::kReset, "", kNow, 5, &lab_), kNow).verdict,
            CommandVerdict::kAccepted);
}

TEST_F(CommandAuth, WrongKeyWithTheRightIdIsABadSignature) {
  CommandKey forged = key("operator", 2);  // same id, different secret
  auto r = verifier_.verify(make_command(CommandKind::kReset, "", kNow, 1, &forged), kNow);
  EXPECT_EQ(r.verdict, CommandVerdict::kBadSignature);
  // ... and it did not consume sequence 1 for the real operator.
  EXPECT_EQ(verifier_.verify(signed_cmd(CommandKind::kReset, 1), kNow).verdict,
            CommandVerdict::kAccepted);
}

TEST_F(CommandAuth, UnknownKeyIdIsRefused) {
  CommandKey stranger = key("stranger", 1);
  EXPECT_EQ(
      verifier_.verify(make_command(CommandKind::kReset, "", kNow, 1, &stranger), kNow).verdict,
      CommandVerdict::kUnknownKey);
}

TEST_F(CommandAuth, UnsignedMotionCommandsAreRefused) {
  for (auto kind : {CommandKind::kStartProgram, CommandKind::kReset, CommandKind::kStop}) {
    auto r = verifier_.verify(make_command(kind, "paper", kNow, 1, nullptr), kNow);
    EXPECT_EQ(r.verdict, CommandVerdict::kUnsigned) << to_string(kind);
  }
  EXPECT_EQ(verifier_.count(CommandVerdict::kUnsigned), 3u);
}

TEST_F(CommandAuth, EstopIsAcceptedFromAnyone) {
  // Unsigned, stale, replayed, with a garbage signature: a stop request still stops.
  auto unsigned_estop = make_command(CommandKind::kEstop, "", kNow - 3'600'000'000LL, 1, nullptr);
  EXPECT_EQ(verifier_.verify(unsigned_estop, kNow).verdict, CommandVerdict::kAccepted);
  EXPECT_EQ(verifier_.verify(unsigned_estop, kNow).verdict, CommandVerdict::kAccepted);
  auto garbage = unsigned_estop;
  garbage.key_id = "nobody";
  garbage.hmac[5] = 0x42;
  EXPECT_EQ(verifier_.verify(garbage, kNow).verdict, CommandVerdict::kAccepted);
}

TEST_F(CommandAuth, StaleWindowBoundariesAreExact) {
  CommandAuthConfig cfg;  // 2 s old, 1 s ahead
  CommandVerifier v({op_}, cfg);
  std::int64_t seq = 1;
  auto at = [&](std::int64_t utime) {
    return v.verify(signed_cmd(CommandKind::kReset, seq++, utime), kNow).verdict;
  };
  EXPECT_EQ(at(kNow - cfg.max_age_us), CommandVerdict::kAccepted);
  EXPECT_EQ(at(kNow - cfg.max_age_us - 1), CommandVerdict::kStale);
  EXPECT_EQ(at(kNow + cfg.max_future_us), CommandVerdict::kAccepted);
  EXPECT_EQ(at(kNow + cfg.max_future_us + 1), CommandVerdict::kStale);
}

// fuzz/command_verifier found it: the age of a signed message whose sender time is near
// INT64_MIN overflowed (undefined behaviour, caught by the UBSan pass of scripts/test.sh).
TEST_F(CommandAuth, SenderTimesAtTheEndsOfInt64AreStale) {
  constexpr std::int64_t lo = std::numeric_limits<std::int64_t>::min();
  constexpr std::int64_t hi = std::numeric_limits<std::int64_t>::max();
  std::int64_t seq = 1;
  for (const std::int64_t utime : {lo, lo + 1, hi}) {
    const auto r = verifier_.verify(signed_cmd(CommandKind::kReset, seq++, utime), kNow);
    EXPECT_EQ(r.verdict, CommandVerdict::kStale) << utime << ": " << r.reason;
    const auto sp =
        verifier_.verify_setpoint(make_setpoint(0.0, 0.0, 0.0, utime, seq++, &op_), kNow);
    EXPECT_EQ(sp.verdict, CommandVerdict::kStale) << utime << ": " << sp.reason;
  }
  EXPECT_EQ(verifier_.verify(signed_cmd(CommandKind::kReset, seq++, lo), hi).verdict,
            CommandVerdict::kStale);
  EXPECT_EQ(verifier_.verify(signed_cmd(CommandKind::kReset, seq++, hi), lo).verdict,
            CommandVerdict::kStale);
}

TEST_F(CommandAuth, MalformedFieldsAreRefused) {
  auto bad_kind = signed_cmd(CommandKind::kReset, 1);
  bad_kind.kind = 9;
  EXPECT_EQ(verifier_.verify(bad_kind, kNow).verdict, CommandVerdict::kMalformed);
  auto no_program = signed_cmd(CommandKind::kStartProgram, 2, kNow, "");
  EXPECT_EQ(verifier_.verify(no_program, kNow).verdict, CommandVerdict::kMalformed);
  auto long_program = signed_cmd(CommandKind::kStartProgram, 3, kNow, std::string(65, 'a'));
  EXPECT_EQ(verifier_.verify(long_program, kNow).verdict, CommandVerdict::kMalformed);
  auto control_chars = signed_cmd(CommandKind::kStartProgram, 4, kNow, "pa\nper");
  EXPECT_EQ(verifier_.verify(control_chars, kNow).verdict, CommandVerdict::kMalformed);
}

TEST_F(CommandAuth, EncodedRoundTripIsAccepted) {
  const auto bytes = encode(signed_cmd(CommandKind::kStartProgram, 1, kNow, "circle"));
  auto r = verifier_.verify_encoded(bytes.data(), bytes.size(), kNow);
  EXPECT_EQ(r.verdict, CommandVerdict::kAccepted) << r.reason;
  EXPECT_EQ(r.command.program, "circle");
}

// Every single-bit flip of a signed reset is refused. (A reset can never turn
// into an e-stop by one flip: kinds 4 and 3 differ in three bits.)
TEST_F(CommandAuth, EveryFlippedBitIsRefused) {
  const auto good = encode(signed_cmd(CommandKind::kReset, 1000));
  std::size_t refused = 0;
  for (std::size_t bit = 0; bit < good.size() * 8; ++bit) {
    auto bytes = good;
    bytes[bit / 8] ^= static_cast<unsigned char>(1U << (bit % 8));
    CommandVerifier v({op_});
    auto r = v.verify_encoded(bytes.data(), bytes.size(), kNow);
    EXPECT_NE(r.verdict, CommandVerdict::kAccepted) << "bit " << bit << ": " << r.reason;
    refused += r.verdict != CommandVerdict::kAccepted;
  }
  EXPECT_EQ(refused, good.size() * 8);
}

TEST_F(CommandAuth, EveryTruncationAndTrailingGarbageIsMalformed) {
  auto bytes = encode(signed_cmd(CommandKind::kStartProgram, 1, kNow, "paper"));
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    auto r = verifier_.verify_encoded(bytes.data(), n, kNow);
    EXPECT_EQ(r.verdict, CommandVerdict::kMalformed) << "length " << n;
  }
  bytes.push_back(0);
  EXPECT_EQ(verifier_.verify_encoded(bytes.data(), bytes.size(), kNow).verdict,
            CommandVerdict::kMalformed);
  EXPECT_EQ(verifier_.count(CommandVerdict::kMalformed), bytes.size());
}

TEST(CommandAuthVerifier, DuplicateKeyIdsAreAConfigError) {
  EXPECT_THROW(CommandVerifier({key("a", 1), key("a", 2)}), ConfigError);
}

class KeyFile : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/dualv-key-test.XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& content, mode_t mode = 0600) {
    const std::string p = (dir_ / name).string();
    std::ofstream(p, std::ios::binary) << content;
    chmod(p.c_str(), mode);
    return p;
  }
  std::string load_error(const std::string& path) {
    try {
      load_command_key(path);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  }
  std::filesystem::path dir_;
};

TEST_F(KeyFile, RawAndHexKeysLoadWithTheFileStemAsId) {
  std::string raw(32, '\0');
  for (int i = 0; i < 32; ++i) raw[i] = static_cast<char>(i + 1);
  std::vector<std::string> warnings;
  const CommandKey a = load_command_key(write("operator.key", raw), &warnings);
  EXPECT_EQ(a.id, "operator");
  EXPECT_EQ(a.bytes[0], 1);
  EXPECT_EQ(a.bytes[31], 32);
  std::string hex;
  for (int i = 0; i < 32; ++i)
    hex += "0123456789abcdef"[(i + 1) >> 4], hex += "0123456789abcdef"[(i + 1) & 15];
  const CommandKey b = load_command_key(write("lab.hex", hex + "\n"), &warnings);
  EXPECT_EQ(b.id, "lab");
  EXPECT_EQ(b.bytes, a.bytes);
  EXPECT_TRUE(warnings.empty());
}

TEST_F(KeyFile, MissingFileSaysHowToCreateOne) {
  const std::string e = load_error((dir_ / "nope.key").string());
  EXPECT_NE(e.find("No such file"), std::string::npos) << e;
  EXPECT_NE(e.find("head -c 32 /dev/urandom"), std::string::npos) << e;
}

TEST_F(KeyFile, WrongSizeIsNamed) {
  const std::string e = load_error(write("short.key", std::string(31, 'x')));
  EXPECT_NE(e.find("must hold exactly 32 bytes"), std::string::npos) << e;
  EXPECT_NE(e.find("got 31 bytes"), std::string::npos) << e;
  EXPECT_NE(load_error(write("badhex.key", std::string(64, 'g'))).find("64 hex digits"),
            std::string::npos);
}

TEST_F(KeyFile, AllZeroKeyIsRefused) {
  EXPECT_NE(load_error(write("zero.key", std::string(32, '\0'))).find("all zeros"),
            std::string::npos);
}

TEST_F(KeyFile, WorldReadableKeyLoadsWithAWarning) {
  std::vector<std::string> warnings;
  load_command_key(write("open.key", std::string(32, 'k'), 0644), &warnings);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("readable by every user"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("chmod 600"), std::string::npos) << warnings[0];
}

TEST_F(KeyFile, KeyFolderLoadsEveryKeyFileInNameOrder) {
  write("bob.key", std::string(32, 'b'));
  write("alice.key", std::string(32, 'a'));
  write("notes.txt", "not a key");
  std::vector<std::string> warnings;
  const auto keys = load_command_keys(dir_.string(), &warnings);
  ASSERT_EQ(keys.size(), 2u);
  EXPECT_EQ(keys[0].id, "alice");
  EXPECT_EQ(keys[1].id, "bob");
  EXPECT_TRUE(warnings.empty());
}

TEST_F(KeyFile, EmptyKeyFolderWarnsAndMissingOneFails) {
  std::vector<std::string> warnings;
  EXPECT_TRUE(load_command_keys(dir_.string(), &warnings).empty());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("only e-stops"), std::string::npos);
  EXPECT_THROW(load_command_keys((dir_ / "missing").string()), ConfigError);
}

TEST_F(CommandAuth, SignedSetpointsAreAcceptedInOrderAndRefusedOtherwise) {
  const auto sp = make_setpoint(0.01, 0.26, 0.1, kNow, 5, &op_);
  auto r = verifier_.verify_setpoint(sp, kNow);
  EXPECT_EQ(r.verdict, CommandVerdict::kAccepted) << r.reason;
  EXPECT_EQ(r.setpoint.y, 0.26);
  EXPECT_EQ(verifier_.verify_setpoint(sp, kNow).verdict, CommandVerdict::kReplayed);
  EXPECT_EQ(verifier_.verify_setpoint(make_setpoint(0.0, 0.25, 0.0, kNow, 4, &op_), kNow).verdict,
            CommandVerdict::kReplayed);  // out of order
  EXPECT_EQ(
      verifier_.verify_setpoint(make_setpoint(0.0, 0.25, 0.0, kNow, 6, nullptr), kNow).verdict,
      CommandVerdict::kUnsigned);
  auto tampered = make_setpoint(0.0, 0.25, 0.0, kNow, 7, &op_);
  tampered.x = 0.09;  // moved after signing
  EXPECT_EQ(verifier_.verify_setpoint(tampered, kNow).verdict, CommandVerdict::kBadSignature);
  EXPECT_EQ(verifier_.verify_setpoint(make_setpoint(0.0, 0.25, 0.0, kNow - 600'000, 8, &op_), kNow)
                .verdict,
            CommandVerdict::kStale);  // older than max_setpoint_age_us, although a command may be
  EXPECT_EQ(verifier_.verify_setpoint(make_setpoint(std::nan(""), 0.25, 0.0, kNow, 9, &op_), kNow)
                .verdict,
            CommandVerdict::kMalformed);
  EXPECT_EQ(verifier_.verify_setpoint(make_setpoint(0.0, 0.25, 0.0, kNow, 10, &op_), kNow).verdict,
            CommandVerdict::kAccepted);
  EXPECT_EQ(verifier_.setpoint_count(CommandVerdict::kAccepted), 2u);
  EXPECT_EQ(verifier_.count(CommandVerdict::kAccepted), 0u);  // commands counted apart
}

TEST_F(CommandAuth, SetpointAndCommandSequencesAreIndependentAndSignaturesDoNotCross) {
  // A stream at sequence 1000 does not make a later command with a lower sequence a replay.
  EXPECT_EQ(
      verifier_.verify_setpoint(make_setpoint(0.0, 0.25, 0.0, kNow, 1000, &op_), kNow).verdict,
      CommandVerdict::kAccepted);
  EXPECT_EQ(verifier_.verify(signed_cmd(CommandKind::kStop, 10), kNow).verdict,
            CommandVerdict::kAccepted);
  // A setpoint's HMAC over its own encoding: the bytes of a setpoint never verify as a command.
  const auto sp = make_setpoint(0.0, 0.25, 0.0, kNow, 1001, &op_);
  std::vector<unsigned char> b(static_cast<std::size_t>(sp.getEncodedSize()));
  sp.encode(b.data(), 0, static_cast<int>(b.size()));
  EXPECT_EQ(verifier_.verify_encoded(b.data(), b.size(), kNow).verdict, CommandVerdict::kMalformed);
  EXPECT_EQ(verifier_.verify_setpoint_encoded(b.data(), b.size(), kNow).verdict,
            CommandVerdict::kAccepted);
  const auto cmd = encode(signed_cmd(CommandKind::kStop, 11));
  EXPECT_EQ(verifier_.verify_setpoint_encoded(cmd.data(), cmd.size(), kNow).verdict,
            CommandVerdict::kMalformed);
}

}  // namespace
}  // namespace dualv::runtime
