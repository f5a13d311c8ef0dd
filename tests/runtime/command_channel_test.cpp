#include "runtime/command_channel.hpp"

#include <gtest/gtest.h>

#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>
#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "runtime/channels.hpp"
#include "runtime/telemetry_publisher.hpp"

namespace dualv::runtime {
namespace {

CommandKey test_key() {
  CommandKey k;
  k.id = "operator";
  for (std::size_t i = 0; i < kKeyBytes; ++i) k.bytes[i] = static_cast<unsigned char>(3 * i + 1);
  return k;
}

class CommandChannelTest : public ::testing::Test {
 protected:
  lcm::LCM lcm_{"memq://"};
  CommandKey key_ = test_key();
  std::int64_t now_ = 1'750'000'000'000'000;
  CommandChannel channel_{lcm_, CommandVerifier({key_}), [this] { return now_; }};

  void publish(const dualv_lcm::command_t& c) { ASSERT_EQ(lcm_.publish(kCommandChannel, &c), 0); }
  int poll_all() {
    int n = 0;
    while (channel_.poll(0) > 0) ++n;
    return n;
  }
};

TEST_F(CommandChannelTest, VerifiedCommandsReachTheQueueInOrder) {
  publish(make_command(CommandKind::kStartProgram, "paper", now_, 1, &key_));
  publish(make_command(CommandKind::kReset, "", now_, 2, &key_));
  EXPECT_EQ(poll_all(), 2);
  VerifiedCommand v;
  ASSERT_TRUE(channel_.try_pop(v));
  EXPECT_EQ(v.kind, CommandKind::kStartProgram);
  EXPECT_STREQ(v.program, "paper");
  EXPECT_STREQ(v.key_id, "operator");
  EXPECT_TRUE(v.is_signed);
  EXPECT_EQ(v.sequence, 1);
  ASSERT_TRUE(channel_.try_pop(v));
  EXPECT_EQ(v.kind, CommandKind::kReset);
  EXPECT_FALSE(channel_.try_pop(v));
  EXPECT_EQ(channel_.accepted(), 2u);
}

TEST_F(CommandChannelTest, RefusedCommandsAreCountedAndNeverQueued) {
  const auto good = make_command(CommandKind::kStartProgram, "paper", now_, 5, &key_);
  publish(good);
  publish(good);                                                                // replay
  publish(make_command(CommandKind::kReset, "", now_, 6, nullptr));             // unsigned
  publish(make_command(CommandKind::kReset, "", now_ - 60'000'000, 7, &key_));  // stale
  auto tampered = make_command(CommandKind::kStartProgram, "paper", now_, 8, &key_);
  tampered.program = "square";  // changed after signing
  publish(tampered);
  const char garbage[] = "not an lcm command";
  lcm_.publish(kCommandChannel, garbage, sizeof(garbage));  // malformed
  poll_all();
  VerifiedCommand v;
  ASSERT_TRUE(channel_.try_pop(v));
  EXPECT_EQ(v.sequence, 5);
  EXPECT_FALSE(channel_.try_pop(v));
  EXPECT_EQ(channel_.accepted(), 1u);
  EXPECT_EQ(channel_.refused(), 5u);
  const auto& ver = channel_.verifier();
  EXPECT_EQ(ver.count(CommandVerdict::kReplayed), 1u);
  EXPECT_EQ(ver.count(CommandVerdict::kUnsigned), 1u);
  EXPECT_EQ(ver.count(CommandVerdict::kStale), 1u);
  EXPECT_EQ(ver.count(CommandVerdict::kBadSignature), 1u);
  EXPECT_EQ(ver.count(CommandVerdict::kMalformed), 1u);
}

TEST_F(CommandChannelTest, EstopIsCountedEvenWhenTheQueueIsFull) {
  for (std::size_t i = 0; i < CommandChannel::kQueue; ++i)
    publish(make_command(CommandKind::kReset, "", now_, static_cast<std::int64_t>(i + 1), &key_));
  publish(make_command(CommandKind::kEstop, "", now_, 0, nullptr));
  poll_all();
  EXPECT_EQ(channel_.estop_requests(), 1u);
  EXPECT_EQ(channel_.dropped(), 1u);  // the queue was full; the counter still saw it
}

TEST_F(CommandChannelTest, SendCommandUsesIncreasingSequences) {
  auto a = send_command(lcm_, CommandKind::kReset, "", &key_);
  auto b = send_command(lcm_, CommandKind::kReset, "", &key_);
  EXPECT_GT(b.sequence, a.sequence);
  auto e = send_command(lcm_, CommandKind::kEstop, "", nullptr);
  EXPECT_TRUE(e.key_id.empty());
}

TEST_F(CommandChannelTest, BackgroundThreadDeliversCommands) {
  // The channel thread owns the LCM handle while it runs; the test only publishes.
  lcm::LCM local("memq://");
  CommandChannel ch(local, CommandVerifier({key_}));
  ch.start();
  const auto cmd = send_command(local, CommandKind::kEstop, "", nullptr);
  (void)cmd;
  VerifiedCommand v;
  bool got = false;
  for (int i = 0; i < 1000 && !got; ++i) {  // up to 5 s on a loaded CI machine
    got = ch.try_pop(v);
    if (!got) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ch.stop();
  ASSERT_TRUE(got);
  EXPECT_EQ(v.kind, CommandKind::kEstop);
  EXPECT_EQ(ch.estop_requests(), 1u);
}

// Captures every spdlog line while alive (the default logger's sinks swapped for one
// ostream sink), so a test counts what the channel logs.
class LogCapture {
 public:
  LogCapture() : sink_(std::make_shared<spdlog::sinks::ostream_sink_mt>(out_)) {
    auto logger = std::make_shared<spdlog::logger>("capture", sink_);
    logger->set_level(spdlog::level::trace);
    logger->set_pattern("%l %v");
    previous_ = spdlog::default_logger();
    spdlog::set_default_logger(logger);
  }
  ~LogCapture() { spdlog::set_default_logger(previous_); }
  std::vector<std::string> lines() const {
    std::vector<std::string> out;
    std::istringstream in(out_.str());
    for (std::string l; std::getline(in, l);) out.push_back(l);
    return out;
  }

 private:
  std::ostringstream out_;
  std::shared_ptr<spdlog::sinks::ostream_sink_mt> sink_;
  std::shared_ptr<spdlog::logger> previous_;
};

// Issue 14, defect 6: 2000 garbage messages over 2 s of (test) clock: every one counted and
// refused, the log bounded: the first kLogBurst lines in full, then at most one summary per
// second (2 s: at most 3 summaries with the final one at stop()).
TEST(CommandChannelLog, GarbageIsCountedAndItsLogRateLimited) {
  LogCapture capture;
  lcm::LCM lcm{"memq://"};
  std::int64_t now = 1'750'000'000'000'000;
  std::uint64_t malformed = 0;
  {
    CommandChannel ch(lcm, CommandVerifier({test_key()}), [&] { return now; });
    for (int i = 0; i < 2000; ++i) {
      const std::string garbage = "garbage " + std::to_string(i);
      ASSERT_EQ(lcm.publish(kCommandChannel, garbage.data(), static_cast<unsigned>(garbage.size())),
                0);
      while (ch.poll(0) > 0) {
      }
      now += 1000;  // 1 ms per message
    }
    EXPECT_EQ(ch.refused(), 2000u);
    EXPECT_EQ(ch.accepted(), 0u);
    malformed = ch.verifier().count(CommandVerdict::kMalformed);
    ch.stop();
  }
  EXPECT_EQ(malformed, 2000u);
  const auto lines = capture.lines();
  std::size_t full = 0, summaries = 0;
  std::uint64_t summarised = 0;
  for (const auto& l : lines) {
    if (l.find("command refused (malformed)") != std::string::npos) ++full;
    const auto at = l.find("more refused commands not logged");
    if (at != std::string::npos) {
      ++summaries;
      summarised += std::stoull(l.substr(l.find("channel: ") + 9));
      EXPECT_NE(l.find("malformed "), std::string::npos) << l;
    }
  }
  EXPECT_EQ(full, CommandChannel::kLogBurst);
  EXPECT_GE(summaries, 1u);
  EXPECT_LE(summaries, 3u);
  EXPECT_EQ(full + summarised, 2000u);  // every message either logged or in a summary count
  EXPECT_LE(lines.size(), CommandChannel::kLogBurst + 3);
}

// 200 accepted unsigned e-stops with nobody reading the queue (64 deep): every one counts as an
// e-stop request, the accepted and queue-full lines are bounded the same way.
TEST(CommandChannelLog, EstopFloodOnAFullQueueIsCountedNotLoggedPerMessage) {
  LogCapture capture;
  lcm::LCM lcm{"memq://"};
  std::int64_t now = 1'750'000'000'000'000;
  {
    CommandChannel ch(lcm, CommandVerifier({test_key()}), [&] { return now; });
    for (int i = 0; i < 200; ++i) {
      const auto e = make_command(CommandKind::kEstop, "", now, i, nullptr);
      ASSERT_EQ(lcm.publish(kCommandChannel, &e), 0);
      while (ch.poll(0) > 0) {
      }
      now += 1000;
    }
    EXPECT_EQ(ch.estop_requests(), 200u);
    EXPECT_EQ(ch.accepted(), 200u);
    EXPECT_EQ(ch.dropped(), 200u - CommandChannel::kQueue);
  }
  EXPECT_LE(capture.lines().size(), 2 * (CommandChannel::kLogBurst + 2));
}

}  // namespace
}  // namespace dualv::runtime
