// A signed start cannot be replayed after the service restarts (issue 14, defect 5;
// runtime/replay_state.hpp, docs/safety.md). A "restart" is a second CommandVerifier (and a
// second CommandChannel) on the same state file; the replay is the very bytes accepted by the
// first one, 0.5 s and 1.5 s after signing, within the 2 s age window.
#include "runtime/replay_state.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

#include "runtime/channels.hpp"
#include "runtime/command_auth.hpp"
#include "runtime/command_channel.hpp"

namespace dualv::runtime {
namespace {

constexpr std::int64_t kSigned = 1'750'000'000'000'000;  // us since 1970

CommandKey op_key() {
  CommandKey k;
  k.id = "operator";
  for (std::size_t i = 0; i < kKeyBytes; ++i) k.bytes[i] = static_cast<unsigned char>(5 + i);
  return k;
}

class ReplayState : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::path(::testing::TempDir()) /
           ("dualv_replay_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    cfg_.replay_state_file = (dir_ / "replay-state").string();
    // An installed service starts from an empty, valid state (a missing file is the lost-
    // state case, MissingOrCorruptFileRefusesWhatARestartCouldReplay).
    ASSERT_EQ(save_replay_state(cfg_.replay_state_file, {}), "");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir_;
  CommandAuthConfig cfg_;
  CommandKey key_ = op_key();
};

TEST_F(ReplayState, SignedStartIsNotAcceptedAgainAfterARestart) {
  const auto start = make_command(CommandKind::kStartProgram, "paper", kSigned, kSigned, &key_);
  {
    CommandVerifier first({key_}, cfg_);
    ASSERT_EQ(first.verify(start, kSigned + 100'000).verdict, CommandVerdict::kAccepted);
  }
  for (std::int64_t after : {500'000, 1'500'000}) {
    CommandVerifier restarted({key_}, cfg_);
    EXPECT_NE(restarted.state_note().find("1 marks loaded"), std::string::npos)
        << restarted.state_note();
    const VerifyResult r = restarted.verify(start, kSigned + after);
    EXPECT_EQ(r.verdict, CommandVerdict::kReplayed) << after << ": " << r.reason;
  }
  // A new command (later sequence) from the same operator is accepted after the restart.
  CommandVerifier restarted({key_}, cfg_);
  const auto next = make_command(CommandKind::kStartProgram, "paper", kSigned + 1'000'000,
                                 kSigned + 1'000'000, &key_);
  EXPECT_EQ(restarted.verify(next, kSigned + 1'100'000).verdict, CommandVerdict::kAccepted);
  // Without a state file (the old behaviour) the same replay would pass: the file is what
  // makes the difference.
  CommandVerifier in_memory({key_});
  EXPECT_EQ(in_memory.verify(start, kSigned + 500'000).verdict, CommandVerdict::kAccepted);
}

TEST_F(ReplayState, SetpointMarksPersistToo) {
  const auto sp = make_setpoint(0.0, 0.25, 0.0, kSigned, 42, &key_);
  {
    CommandVerifier first({key_}, cfg_);
    ASSERT_EQ(first.verify_setpoint(sp, kSigned + 1000).verdict, CommandVerdict::kAccepted);
  }
  CommandVerifier restarted({key_}, cfg_);
  EXPECT_EQ(restarted.verify_setpoint(sp, kSigned + 2000).verdict, CommandVerdict::kReplayed);
}

// Two CommandChannels on one state file, as two lives of `dualv run --serve`: the exact bytes
// the first accepted are refused by the second.
TEST_F(ReplayState, RestartedChannelRefusesTheCapturedMessage) {
  lcm::LCM lcm{"memq://"};
  std::int64_t now = kSigned + 100'000;
  const auto start = make_command(CommandKind::kStartProgram, "paper", kSigned, kSigned, &key_);
  {
    CommandChannel first(lcm, CommandVerifier({key_}, cfg_), [&] { return now; });
    ASSERT_EQ(lcm.publish(kCommandChannel, &start), 0);
    while (first.poll(0) > 0) {
    }
    EXPECT_EQ(first.accepted(), 1u);
  }
  now = kSigned + 500'000;
  CommandChannel second(lcm, CommandVerifier({key_}, cfg_), [&] { return now; });
  ASSERT_EQ(lcm.publish(kCommandChannel, &start), 0);
  while (second.poll(0) > 0) {
  }
  EXPECT_EQ(second.accepted(), 0u);
  EXPECT_EQ(second.verifier().count(CommandVerdict::kReplayed), 1u);
  VerifiedCommand v;
  EXPECT_FALSE(second.try_pop(v));
}

// Lost state (no file: first start, or deleted; a corrupt one): nothing that could have been
// signed before the restart is accepted; a command sent after the window passes is.
TEST_F(ReplayState, MissingOrCorruptFileRefusesWhatARestartCouldReplay) {
  for (const char* content : {static_cast<const char*>(nullptr), "garbage\n",
                              "dualv-replay-state 1\ncommand 6f70 5\n" /* cut: no end line */}) {
    std::filesystem::remove(cfg_.replay_state_file);
    if (content) std::ofstream(cfg_.replay_state_file) << content;
    CommandVerifier v({key_}, cfg_);
    EXPECT_NE(v.state_note().find(content ? "corrupt" : "missing"), std::string::npos)
        << v.state_note();
    const auto old = make_command(CommandKind::kReset, "", kSigned, kSigned, &key_);
    EXPECT_EQ(v.verify(old, kSigned + 500'000).verdict, CommandVerdict::kReplayed);
    // Sent within max_future_us (1 s) of the first message seen: could predate the restart.
    const auto soon =
        make_command(CommandKind::kReset, "", kSigned + 1'400'000, kSigned + 1'400'000, &key_);
    EXPECT_EQ(v.verify(soon, kSigned + 1'450'000).verdict, CommandVerdict::kReplayed);
    const auto later =
        make_command(CommandKind::kReset, "", kSigned + 1'600'000, kSigned + 1'600'000, &key_);
    EXPECT_EQ(v.verify(later, kSigned + 1'650'000).verdict, CommandVerdict::kAccepted);
    // ... and a valid file is written for the next restart.
    EXPECT_EQ(load_replay_state(cfg_.replay_state_file).status, ReplayStateStatus::kLoaded);
  }
}

TEST_F(ReplayState, FileRoundTripsAndIsWrittenAtomically) {
  ReplayMarks m;
  m.commands["operator"] = 17;
  m.commands["key with spaces"] = -3;
  m.setpoints["operator"] = 1'750'000'000'000'000;
  ASSERT_EQ(save_replay_state(cfg_.replay_state_file, m), "");
  // Nothing but the state file is left in the folder (no temporary file).
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir_))
    names.push_back(e.path().filename().string());
  EXPECT_EQ(names, std::vector<std::string>{"replay-state"});
  const LoadedReplayState back = load_replay_state(cfg_.replay_state_file);
  ASSERT_EQ(back.status, ReplayStateStatus::kLoaded) << back.message;
  EXPECT_EQ(back.marks.commands, m.commands);
  EXPECT_EQ(back.marks.setpoints, m.setpoints);
  // A save into a folder that does not exist fails, says why, and leaves nothing behind.
  const std::string bad = (dir_ / "nope" / "state").string();
  EXPECT_NE(save_replay_state(bad, m).find("cannot create"), std::string::npos);
}

// A first use (the folder does not exist: nothing was ever accepted there) starts from an
// empty, valid state; an existing folder without the file is a lost state and stays missing.
TEST_F(ReplayState, FirstUseCreatesAnEmptyStateOnlyWhenTheFolderIsNew) {
  const std::string fresh = (dir_ / "new" / "deeper" / "replay.state").string();
  const std::string note = create_replay_state_on_first_use(fresh);
  EXPECT_NE(note.find("created empty"), std::string::npos) << note;
  const LoadedReplayState st = load_replay_state(fresh);
  ASSERT_EQ(st.status, ReplayStateStatus::kLoaded) << st.message;
  EXPECT_TRUE(st.marks.commands.empty() && st.marks.setpoints.empty());
  // Only its owner may read the marks' folder.
  const auto perms = std::filesystem::status(dir_ / "new" / "deeper").permissions();
  EXPECT_EQ(perms & std::filesystem::perms::all, std::filesystem::perms::owner_all);
  // A signed start is accepted at once from that state (no lost-state window).
  CommandAuthConfig cfg;
  cfg.replay_state_file = fresh;
  CommandVerifier v({key_}, cfg);
  const auto start = make_command(CommandKind::kStartProgram, "paper", kSigned, kSigned, &key_);
  EXPECT_EQ(v.verify(start, kSigned + 1000).verdict, CommandVerdict::kAccepted);

  // The folder exists now: deleting the file is a lost state, not a first use.
  std::filesystem::remove(fresh);
  EXPECT_EQ(create_replay_state_on_first_use(fresh), "");
  EXPECT_EQ(load_replay_state(fresh).status, ReplayStateStatus::kMissing);
  // A folder that cannot be made is an error naming the file.
  std::ofstream(dir_ / "plain-file") << "x";
  try {
    create_replay_state_on_first_use((dir_ / "plain-file" / "sub" / "replay.state").string());
    ADD_FAILURE() << "no error for a folder under a plain file";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("plain-file"), std::string::npos) << e.what();
  }
}

// packaging/postinst writes the packaged service's first state by hand (no dualv needed at
// install time): it must be the empty state this loader accepts.
TEST_F(ReplayState, ThePackagesFirstStateIsAnEmptyValidState) {
  std::ifstream in(std::string(DUALV_SOURCE_DIR) + "/packaging/postinst");
  ASSERT_TRUE(in) << "packaging/postinst";
  std::string line, printed;
  const std::string marker = "printf '";
  while (std::getline(in, line))
    if (line.find("replay.state") != std::string::npos && line.find(marker) != std::string::npos) {
      const auto from = line.find(marker) + marker.size();
      printed = line.substr(from, line.find('\'', from) - from);
    }
  ASSERT_FALSE(printed.empty()) << "no printf '...' > .../replay.state line in packaging/postinst";
  std::string text;  // printf's \n
  for (std::size_t i = 0; i < printed.size(); ++i) {
    if (printed[i] == '\\' && i + 1 < printed.size() && printed[i + 1] == 'n') {
      text += '\n';
      ++i;
    } else {
      text += printed[i];
    }
  }
  std::ofstream(cfg_.replay_state_file) << text;
  const LoadedReplayState st = load_replay_state(cfg_.replay_state_file);
  ASSERT_EQ(st.status, ReplayStateStatus::kLoaded) << st.message << "\n" << text;
  EXPECT_TRUE(st.marks.commands.empty() && st.marks.setpoints.empty());
}

}  // namespace
}  // namespace dualv::runtime
