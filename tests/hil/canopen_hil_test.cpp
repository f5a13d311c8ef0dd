// The CANopen master on real SocketCAN (vcan0), inside user-mode-linux in CI: a second
// process (this binary with --fake-drives) plays four scripted CiA 402 drives
// (tests/drivers/canopen/fake_slave.hpp) on its own sockets; the test boots them with
// open_canopen_drives(), runs a 1 kHz loop, and checks the boot frames and the cyclic
// traffic on a third socket, plus foreign frames injected with cansend (can-utils).
// With --emulator DUALV_BINARY --config CONFIG_YAML, CanopenHilEmulator runs the master
// against `dualv sim --can vcan0` (sim/drive_emulator.hpp) as the second process.
// Behaviour and ordering only, never latency: the guest's timing is coarse, and under host
// load (ctest -j, other builds) either process can stall for a second or more. So nothing
// here waits a fixed time or a fixed number of cycles for the other process: every wait is
// for a condition, bounded by a generous deadline (kPatience) that only a broken peer hits,
// and the master's detection timeouts are far longer than any stall (hil_config()).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "canopen/fake_slave.hpp"
#include "drivers/canopen/boot.hpp"
#include "drivers/canopen_setup.hpp"

extern char** environ;

namespace dualv::drivers {
namespace {

constexpr const char* kIface = "vcan0";
// How long a wait for the other process may take before the test calls it broken: far
// beyond any scheduling stall of a loaded guest, far below the guest's own timeout.
constexpr std::uint64_t kPatience_ns = 30'000'000'000ull;

std::uint64_t mono_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ull +
         static_cast<std::uint64_t>(ts.tv_nsec);
}
void sleep_until(std::uint64_t t) {
  timespec ts{static_cast<time_t>(t / 1'000'000'000ull), static_cast<long>(t % 1'000'000'000ull)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

// Set by main() from --emulator DUALV_BINARY --config CONFIG_YAML (the two-process test
// against `dualv sim --can vcan0`); the test is skipped without them.
std::string g_dualv_binary;
std::string g_config;

// ---- the fake drives process --------------------------------------------------------------
volatile sig_atomic_t g_stop = 0;

int run_fake_drives(int argc, char** argv) {
  int refuse_boot = 0;  // node id that never boots
  for (int i = 2; i < argc; ++i)
    if (std::strcmp(argv[i], "--no-boot") == 0 && i + 1 < argc) refuse_boot = std::atoi(argv[++i]);
  signal(SIGTERM, [](int) { g_stop = 1; });
  std::vector<std::unique_ptr<SocketCanBus>> buses;
  std::vector<std::unique_ptr<test::FakeSlave>> slaves;
  for (std::uint8_t id = 1; id <= 4; ++id) {
    SocketCanConfig c;
    c.interface = kIface;
    c.receive_buffer_bytes = 1 << 20;
    buses.push_back(std::make_unique<SocketCanBus>(c));
    slaves.push_back(std::make_unique<test::FakeSlave>(*buses.back(), id));
    slaves.back()->boots = id != refuse_boot;
    slaves.back()->position = 1000 * id;
  }
  // Tell the parent the sockets are open (fd 3 is the write end of its pipe).
  const char ready = 'r';
  (void)!write(3, &ready, 1);
  close(3);
  const std::uint64_t end = mono_ns() + 60'000'000'000ull;
  while (!g_stop && mono_ns() < end && getppid() != 1) {
    for (auto& s : slaves) {
      s->step();
      s->tick(mono_ns());
      s->controlwords.clear();
      s->applied_torques.clear();
    }
    (void)buses[0]->wait_readable(std::chrono::microseconds(200));
  }
  return 0;
}

// ---- helpers for the tests ---------------------------------------------------------------
struct FakeDrives {
  explicit FakeDrives(std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"/proc/self/exe", "--fake-drives"};
    args.insert(args.end(), extra.begin(), extra.end());
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    char self[4096] = {};
    const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n > 0) self[n] = 0;
    int fds[2] = {-1, -1};
    if (pipe(fds) != 0) return;
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], 3);
    if (posix_spawn(&pid, self, &actions, nullptr, argv.data(), environ) != 0) pid = -1;
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    // Wait (bounded) until its sockets are open, so none of the master's frames is missed.
    pollfd p{fds[0], POLLIN, 0};
    char c = 0;
    if (poll(&p, 1, static_cast<int>(kPatience_ns / 1'000'000)) != 1 || read(fds[0], &c, 1) != 1) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
      pid = -1;
    }
    close(fds[0]);
  }
  ~FakeDrives() {
    if (pid > 0) {
      kill(pid, SIGTERM);
      int status = 0;
      waitpid(pid, &status, 0);
    }
  }
  pid_t pid = -1;
};

// The master's timeouts are detection thresholds for a dead peer; here the peer is a
// process in a loaded guest that may stall for seconds and is never dead. So every timeout
// that the fake drives' response time feeds into is set far above any stall: SDO answers,
// boot-ups, CiA 402 transitions and the drives' heartbeats as the master consumes them
// (an expired one would turn the health Stale and hide the states the test checks). The
// fake drives consume no master heartbeat; its 1016h entry is only written and read back.
// The timing checks themselves are unit-tested on a simulated clock (tests/drivers).
CanConfig hil_config() {
  CanConfig c = default_can_config();
  c.interface = kIface;
  c.boot_timeout_ns = 20'000'000'000;
  c.drive_heartbeat_timeout_ns = 20'000'000'000;
  c.master_heartbeat_timeout_ns = 20'000'000'000;
  c.sdo_timeout_ns = 10'000'000'000;
  c.transition_timeout_ns = 20'000'000'000;
  return c;
}

std::vector<fw::CanFrame> drain(SocketCanBus& bus) {
  std::vector<fw::CanFrame> out;
  fw::CanFrame f;
  while (bus.receive(f) == BusStatus::kOk) out.push_back(f);
  return out;
}

TEST(CanopenHil, BootsFourDrivesAndRunsCyclesOverVcan) {
  SocketCanConfig sc;
  sc.interface = kIface;
  sc.receive_buffer_bytes = 4 << 20;
  SocketCanBus sniffer(sc);
  FakeDrives drives;
  ASSERT_GT(drives.pid, 0);
  std::vector<fw::CanFrame> wire;

  CanopenSetupOptions opt;
  opt.control_period_s = 0.001;
  // The boot sends several hundred frames: a thread drains the sniffer meanwhile so its
  // socket buffer (capped by rmem_max) never overflows.
  std::atomic<bool> booting{true};
  std::thread drainer([&] {
    while (booting.load()) {
      (void)sniffer.wait_readable(std::chrono::milliseconds(5));
      for (auto& f : drain(sniffer)) wire.push_back(f);
    }
  });
  std::unique_ptr<CanopenDrives> d;
  try {
    d = open_canopen_drives(hil_config(), opt);
  } catch (...) {
    booting = false;
    drainer.join();
    throw;
  }
  booting = false;
  drainer.join();
  for (auto& f : drain(sniffer)) wire.push_back(f);

  // Boot frames, in order: NMT reset of nodes 1..4, four boot-ups, SDO configuration of
  // node 1 first, NMT start of nodes 1..4 after every SDO.
  std::vector<std::string> text;
  for (const auto& f : wire) text.push_back(test::to_text(f));
  const auto at = [&](const std::string& s) {
    return std::find(text.begin(), text.end(), s) - text.begin();
  };
  const std::vector<std::string> resets = {"000#8101", "000#8102", "000#8103", "000#8104"};
  for (std::size_t i = 0; i < resets.size(); ++i)
    ASSERT_LT(at(resets[i]), static_cast<long>(text.size())) << resets[i];
  EXPECT_LT(at("000#8101"), at("000#8104"));
  // Each node's boot-up follows its own reset (they may interleave with the others').
  for (int n = 1; n <= 4; ++n) {
    const std::string reset = "000#810" + std::to_string(n);
    const std::string bootup = "70" + std::to_string(n) + "#00";
    EXPECT_GT(at(bootup), at(reset)) << bootup;
    EXPECT_LT(at(bootup), static_cast<long>(text.size())) << bootup;
  }

  const long first_sdo =
      std::find_if(text.begin(), text.end(),
                   [](const std::string& s) { return s.rfind("601#", 0) == 0; }) -
      text.begin();
  for (const char* b : {"701#00", "702#00", "703#00", "704#00"}) EXPECT_GT(first_sdo, at(b)) << b;
  EXPECT_EQ(text[static_cast<std::size_t>(first_sdo)], "601#4000100000000000");  // 1000h first
  const long last_sdo =
      std::find_if(text.rbegin(), text.rend(),
                   [](const std::string& s) { return s.rfind("60", 0) == 0 && s[3] == '#'; })
          .base() -
      text.begin() - 1;
  EXPECT_LT(last_sdo, at("000#0101"));
  EXPECT_LT(at("000#0101"), at("000#0104"));

  // 1 kHz loop: enable, then 1 N m on every drive, until 300 cycles after all four were
  // enabled and 20 per mille was seen on the wire (however long the fake drives take).
  CanopenActuatorSet& set = d->actuators();
  ActuatorFeedback fb;
  ActuatorCommand cmd;
  cmd.n = 4;
  const auto torque_on_wire = [](const fw::CanFrame& f) {
    return f.id == 0x201 && f.dlc == 4 && fw::decode_rpdo1(f)->target_torque == 20;
  };
  std::uint64_t next = mono_ns();
  const std::uint64_t deadline = next + kPatience_ns;
  int enabled_at = -1;
  bool torque_seen = false;
  int cycles = 0;
  for (; mono_ns() < deadline; ++cycles) {
    if (enabled_at >= 0 && cycles >= enabled_at + 300 && torque_seen) break;
    next += 1'000'000;
    sleep_until(next);
    set.read(fb);
    bool all = true;
    for (int i = 0; i < 4; ++i) all = all && fb.drive[i].state == DriveState::kEnabled;
    if (all && enabled_at < 0) enabled_at = cycles;
    cmd.request = enabled_at < 0 ? DriveRequest::kEnable : DriveRequest::kHold;
    cmd.torque.fill(enabled_at >= 0 ? 1.0 : 0.0);
    set.write(cmd);
    for (auto& f : drain(sniffer)) {
      torque_seen = torque_seen || torque_on_wire(f);
      wire.push_back(f);
    }
  }
  ASSERT_GE(enabled_at, 0) << "drives never all enabled in " << kPatience_ns / 1'000'000'000
                           << " s";
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(fb.drive[i].state, DriveState::kEnabled) << i;
    EXPECT_NEAR(fb.drive[i].position, 1000.0 * (i + 1) * fw::kTwoPi / (1 << 20), 1e-12);
    EXPECT_NE(set.health(i).health, DriveHealth::kError) << set.health(i).reason;
  }
  // On the wire: one SYNC per cycle (plus the prime cycles), 20 per mille once enabled, and
  // never a torque before the drive reported Operation enabled.
  int syncs = 0;
  int torque_frames = 0;
  for (const auto& f : wire) {
    syncs += f.id == 0x080;
    torque_frames += torque_on_wire(f);
  }
  EXPECT_GE(syncs, cycles);
  EXPECT_EQ(static_cast<std::uint64_t>(syncs), set.counters().sync_sent);
  EXPECT_GT(torque_frames, 0);
  const auto first_torque = std::find_if(wire.begin(), wire.end(), torque_on_wire);
  const auto first_enabled = std::find_if(wire.begin(), wire.end(), [](const fw::CanFrame& f) {
    // TPDO1 of node 1 with a statusword saying "Operation enabled".
    if (f.id != 0x181) return false;
    const auto tpdo = fw::decode_tpdo1(f);
    if (!tpdo) return false;
    const auto sw = fw::decode_statusword(tpdo->statusword);
    return sw && sw->state == fw::Cia402State::kOperationEnabled;
  });
  EXPECT_LT(first_enabled - wire.begin(), first_torque - wire.begin())
      << "a torque was sent before node 1 reported Operation enabled";

  // Foreign frames (can-utils): unknown id, a TPDO with a wrong DLC, an EMCY from node 2.
  // Sent by a child process while the master keeps cycling: starting three cansend
  // processes can take seconds in a loaded guest, and a master that stopped reading
  // meanwhile would find its socket's receive queue full of heartbeats and the foreign
  // frames dropped (seen under load with std::system here).
  const char* sh_argv[] = {"sh", "-c",
                           "cansend vcan0 7E5#00 && cansend vcan0 182#0102 && "
                           "cansend vcan0 082#1042100000000000",
                           nullptr};
  pid_t sender = -1;
  ASSERT_EQ(posix_spawnp(&sender, "sh", nullptr, nullptr, const_cast<char**>(sh_argv), environ), 0);
  int sender_status = -1;
  const auto all_counted = [&] {
    return set.counters().unknown_frames >= 1 && set.drive_counters(1).malformed >= 1 &&
           set.emcy(1).last().error_code == 0x4210 && set.health(1).health == DriveHealth::kError;
  };
  // Cycle until cansend is done and the master has counted all three, or the deadline.
  const std::uint64_t until = mono_ns() + kPatience_ns;
  while (!(sender < 0 && all_counted()) && mono_ns() < until) {
    next = mono_ns() + 1'000'000;
    sleep_until(next);
    set.read(fb);
    set.write(cmd);
    if (sender > 0 && waitpid(sender, &sender_status, WNOHANG) == sender) sender = -1;
  }
  if (sender > 0) {
    kill(sender, SIGKILL);
    waitpid(sender, &sender_status, 0);
  }
  ASSERT_TRUE(WIFEXITED(sender_status) && WEXITSTATUS(sender_status) == 0)
      << "cansend failed (status " << sender_status << ")";
  std::string state;  // what the master saw, for a failure message
  for (int i = 0; i < 4; ++i)
    state += describe(set.health(i)) + "; TPDOs " + std::to_string(set.drive_counters(i).tpdos) +
             ", missed " + std::to_string(set.drive_counters(i).missed) + "\n";
  EXPECT_GE(set.counters().unknown_frames, 1u) << state;
  EXPECT_GE(set.drive_counters(1).malformed, 1u) << state;
  EXPECT_EQ(set.emcy(1).last().error_code, 0x4210) << state;
  EXPECT_EQ(set.health(1).health, DriveHealth::kError) << state;
}

TEST(CanopenHil, NodeThatNeverBootsIsNamed) {
  FakeDrives drives({"--no-boot", "3"});
  ASSERT_GT(drives.pid, 0);
  CanConfig c = hil_config();
  // Long enough for nodes 1, 2 and 4 to answer from a stalled process (else they would be
  // named too); node 3 never answers, however long the wait.
  c.boot_timeout_ns = 5'000'000'000;
  try {
    (void)open_canopen_drives(c);
    FAIL() << "booted without node 3";
  } catch (const canopen::BootTimeoutError& e) {
    EXPECT_EQ(e.nodes(), std::vector<std::uint8_t>{3});
    EXPECT_NE(std::string(e.what()).find("node 3 did not boot"), std::string::npos) << e.what();
  }
}

// The drive emulator of sim/ (`dualv sim --can vcan0`) as the second process: the master
// boots its four drives from the same `can:` section, enables them and drives torque.
TEST(CanopenHilEmulator, BootsEmulatedDrivesToOperationEnabled) {
  if (g_dualv_binary.empty() || g_config.empty())
    GTEST_SKIP() << "needs --emulator DUALV_BINARY --config CONFIG_YAML";
  SocketCanConfig sc;
  sc.interface = kIface;
  sc.receive_buffer_bytes = 1 << 20;
  SocketCanBus sniffer(sc);
  // --rpdo-watchdog 0: the guest's ms-scale scheduling jitter would trip a 3-cycle watchdog;
  // behaviour, not latency, is under test here.
  std::vector<std::string> args = {g_dualv_binary,   "sim",    "--can",           kIface,
                                   "--config",       g_config, "--exit-after",    "60",
                                   "--status-every", "0",      "--rpdo-watchdog", "0"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  ASSERT_EQ(posix_spawn(&pid, g_dualv_binary.c_str(), &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  struct Reap {
    pid_t pid;
    ~Reap() {
      kill(pid, SIGTERM);
      waitpid(pid, nullptr, 0);
    }
  } reap{pid};
  // Its power-on boot-up messages say it is on the bus (bounded wait).
  bool up = false;
  const std::uint64_t deadline = mono_ns() + kPatience_ns;
  while (!up && mono_ns() < deadline) {
    (void)sniffer.wait_readable(std::chrono::milliseconds(10));
    for (const auto& f : drain(sniffer)) up = up || (f.id == 0x704 && f.dlc == 1 && f.data[0] == 0);
  }
  ASSERT_TRUE(up) << "dualv sim sent no boot-up on vcan0";

  CanConfig c = load_can_config_file(g_config);
  c.interface = kIface;
  c.rpdo_deadline_ns = 0;  // same reason as --rpdo-watchdog 0
  // Far above any stall of either process (see hil_config()); the emulator consumes the
  // master's heartbeat, so that timeout matters here too.
  const CanConfig patient = hil_config();
  c.drive_heartbeat_timeout_ns = patient.drive_heartbeat_timeout_ns;
  c.master_heartbeat_timeout_ns = patient.master_heartbeat_timeout_ns;
  c.sdo_timeout_ns = patient.sdo_timeout_ns;
  c.boot_timeout_ns = patient.boot_timeout_ns;
  c.transition_timeout_ns = patient.transition_timeout_ns;
  std::unique_ptr<CanopenDrives> d = open_canopen_drives(c);
  CanopenActuatorSet& set = d->actuators();
  ActuatorFeedback fb;
  ActuatorCommand cmd;
  cmd.n = set.size();
  std::uint64_t next = mono_ns();
  int enabled_at = -1;
  double q0 = 0.0;
  // Until 500 cycles of torque after all drives were enabled (however long that takes).
  const std::uint64_t loop_deadline = next + kPatience_ns;
  for (int k = 0; mono_ns() < loop_deadline; ++k) {
    if (enabled_at >= 0 && k >= enabled_at + 500) break;
    next += 1'000'000;
    sleep_until(next);
    set.read(fb);
    bool all = true;
    for (int i = 0; i < set.size(); ++i) all = all && fb.drive[i].state == DriveState::kEnabled;
    if (all && enabled_at < 0) {
      enabled_at = k;
      q0 = fb.drive[0].position;
    }
    cmd.request = enabled_at < 0 ? DriveRequest::kEnable : DriveRequest::kHold;
    cmd.torque.fill(enabled_at >= 0 ? 0.5 : 0.0);
    set.write(cmd);
    (void)drain(sniffer);
  }
  ASSERT_GE(enabled_at, 0) << describe(set.health(0));
  for (int i = 0; i < set.size(); ++i) {
    EXPECT_EQ(fb.drive[i].state, DriveState::kEnabled) << describe(set.health(i));
    EXPECT_TRUE(std::isfinite(fb.drive[i].position));
  }
  EXPECT_NE(fb.drive[0].position, q0);  // the simulated mechanism moved under torque
  EXPECT_EQ(set.counters().unknown_frames, 0u);
}

}  // namespace
}  // namespace dualv::drivers

int main(int argc, char** argv) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::strcmp(argv[i], "--emulator") == 0) dualv::drivers::g_dualv_binary = argv[i + 1];
    if (std::strcmp(argv[i], "--config") == 0) dualv::drivers::g_config = argv[i + 1];
  }
  if (argc > 1 && std::strcmp(argv[1], "--fake-drives") == 0)
    return dualv::drivers::run_fake_drives(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
