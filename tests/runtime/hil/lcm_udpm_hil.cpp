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

}  // namespace
}  // namespace dualv::runtime
