// LCM over UDP multicast between two processes: telemetry one way, a signed
// command the other. Runs only under tests/hil/run_in_vcan.sh in a private
// network stack (user-mode-linux guest or a fresh network namespace, where
// loopback multicast is routed): docs/architecture.md forbids multicast on the host network.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <thread>

#include "dualv_lcm/robot_state_t.hpp"
#include "runtime/channels.hpp"
#include "runtime/command_channel.hpp"
#include "runtime/lcm_url.hpp"
#include "runtime/telemetry_publisher.hpp"

namespace dualv::runtime {
namespace {

bool private_network() {
  const char* mode = std::getenv("DUALV_HIL");
  return mode != nullptr && (std::string(mode) == "uml" || std::string(mode) == "netns");
}

CommandKey shared_key() {
  CommandKey k;
  k.id = "hil";
  for (std::size_t i = 0; i < kKeyBytes; ++i) k.bytes[i] = static_cast<unsigned char>(i * 7 + 1);
  return k;
}

struct StateCounter {
  int count = 0;
  std::int64_t last_cycle = -1;
  static void on_raw(const lcm_recv_buf_t* rb, const char*, void* user) {
    auto* self = static_cast<StateCounter*>(user);
    dualv_lcm::robot_state_t m;
    if (m.decode(rb->data, 0, static_cast<int>(rb->data_size)) < 0) return;
    ++self->count;
    self->last_cycle = m.cycle;
  }
};

// The child: a robot-side publisher that also sends a signed reset now and
// then (as `dualv reset` would from another process), until it is killed.
[[noreturn]] void child_main() {
  const CommandKey key = shared_key();
  TelemetryPublisher pub(kLiveUrl);
  lcm::LCM cmd_lcm(kLiveUrl);
  for (std::int64_t cycle = 0; cycle < 2000; ++cycle) {
    StateSample s;
    s.cycle = cycle;
    s.n = 4;
    pub.push_state(s);
    pub.drain();
    if (cycle % 10 == 0) send_command(cmd_lcm, CommandKind::kReset, "", &key);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  _exit(0);
}

TEST(LcmUdpm, TelemetryAndSignedCommandsCrossProcesses) {
  if (!private_network())
    GTEST_SKIP() << "needs the private network of tests/hil/run_in_vcan.sh (DUALV_HIL=uml|netns)";
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) child_main();

  lcm::LCM state_lcm(kLiveUrl);
  ASSERT_TRUE(state_lcm.good());
  StateCounter states;
  lcm_subscribe(state_lcm.getUnderlyingLCM(), kStateChannel, &StateCounter::on_raw, &states);
  CommandChannel commands(kLiveUrl, CommandVerifier({shared_key()}));

  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
  VerifiedCommand v;
  bool got_command = false;
  while (std::chrono::steady_clock::now() < deadline && (states.count < 20 || !got_command)) {
    state_lcm.handleTimeout(10);
    commands.poll(10);
    if (commands.try_pop(v)) got_command = true;
  }
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);

  EXPECT_GE(states.count, 20);
  EXPECT_GE(states.last_cycle, 19);
  ASSERT_TRUE(got_command);
  EXPECT_EQ(v.kind, CommandKind::kReset);
  EXPECT_STREQ(v.key_id, "hil");
  EXPECT_EQ(commands.verifier().count(CommandVerdict::kBadSignature), 0u);
}

// The robot side of `dualv run --lcm kLiveUrl` under load: telemetry as fast as it can go
// (well above the loop's 1 kHz), with `dualv estop`'s three e-stops on the command URL
// (runtime/lcm_url.hpp) in the middle of it.
[[noreturn]] void flooding_child_main() {
  TelemetryPublisher pub(kLiveUrl);
  lcm::LCM cmd_lcm(command_url(kLiveUrl));
  for (std::int64_t cycle = 0; cycle < 4000; ++cycle) {
    StateSample s;
    s.cycle = cycle;
    s.n = 4;
    pub.push_state(s);
    pub.drain();
    if (cycle == 2000)
      for (int i = 0; i < 3; ++i) send_command(cmd_lcm, CommandKind::kEstop, "", nullptr);
  }
  _exit(0);
}

// The command channel `dualv run` opens on the command URL receives the commands and no
// telemetry: an e-stop never waits behind (or is dropped for) robot states in LCM's receive
// queue, as it did when both shared a port (~1 s late in this guest). Counts, not times: a
// subscriber to the robot states on the command side sees none, one on the telemetry URL
// sees them (so there was telemetry to leak), and all three e-stops arrive.
TEST(LcmUdpm, CommandsOnTheirOwnPortNeverSeeTheTelemetry) {
  if (!private_network())
    GTEST_SKIP() << "needs the private network of tests/hil/run_in_vcan.sh (DUALV_HIL=uml|netns)";
  lcm::LCM state_lcm(kLiveUrl);
  ASSERT_TRUE(state_lcm.good());
  StateCounter states;
  lcm_subscribe(state_lcm.getUnderlyingLCM(), kStateChannel, &StateCounter::on_raw, &states);
  lcm::LCM command_side(command_url(kLiveUrl));
  ASSERT_TRUE(command_side.good());
  StateCounter leaked;
  lcm_subscribe(command_side.getUnderlyingLCM(), kStateChannel, &StateCounter::on_raw, &leaked);
  CommandChannel commands(command_side, CommandVerifier({}));
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) flooding_child_main();

  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline &&
         (commands.estop_requests() < 3 || states.count == 0)) {
    commands.poll(5);
    state_lcm.handleTimeout(0);
  }
  waitpid(child, nullptr, 0);
  // Whatever was still on its way to the command side.
  for (int idle = 0; idle < 20;) idle = commands.poll(10) > 0 ? 0 : idle + 1;

  EXPECT_EQ(commands.estop_requests(), 3u);
  EXPECT_GT(states.count, 0) << "no telemetry was published: the test shows nothing";
  EXPECT_EQ(leaked.count, 0) << "robot states reached the command channel's socket";
}

}  // namespace
}  // namespace dualv::runtime
