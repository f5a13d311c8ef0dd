#include "runtime/command_channel.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <thread>

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

}  // namespace
}  // namespace dualv::runtime
