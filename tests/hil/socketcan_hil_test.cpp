// SocketCanBus on a real SocketCAN stack (vcan0, vcan1), run through run_in_vcan.sh: inside
// user-mode-linux on build machines and CI, directly on a host with vcan. Interoperates with
// can-utils (cansend, candump). Timing inside the guest is coarse: these tests assert
// behaviour and ordering, never latency; waits are bounded polls, never fixed sleeps that
// a test depends on.
#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "drivers/can/socketcan_bus.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::drivers {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

constexpr auto kWait = 2s;  // generous: the UML guest is slow and single-CPU

fw::CanFrame frame(std::uint32_t id, std::vector<std::uint8_t> bytes, bool extended = false) {
  fw::CanFrame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    f.data[i] = bytes[i];
  }
  return f;
}

SocketCanConfig config(const std::string& ifname, std::vector<CanFilter> filters = {}) {
  SocketCanConfig c;
  c.interface = ifname;
  c.filters = std::move(filters);
  return c;
}

std::uint64_t realtime_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ULL +
         static_cast<std::uint64_t>(ts.tv_nsec);
}

// Everything that arrives within `quiet` of the previous frame.
std::vector<fw::CanFrame> collect(SocketCanBus& bus, std::chrono::nanoseconds quiet = 300ms) {
  std::vector<fw::CanFrame> out;
  fw::CanFrame f;
  while (bus.receive_for(f, quiet) == BusStatus::kOk) {
    out.push_back(f);
  }
  return out;
}

// Sends a raw SocketCAN frame (e.g. an error frame) the way a controller driver would report
// it: vcan delivers it to every socket whose error mask matches.
void inject_raw(const std::string& ifname, std::uint32_t can_id, std::array<std::uint8_t, 8> data) {
  const int fd = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  ASSERT_GE(fd, 0);
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(if_nametoindex(ifname.c_str()));
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  can_frame cf{};
  cf.can_id = can_id;
  cf.len = CAN_ERR_DLC;
  std::memcpy(cf.data, data.data(), 8);
  ASSERT_EQ(::write(fd, &cf, sizeof(cf)), static_cast<ssize_t>(sizeof(cf))) << strerror(errno);
  ::close(fd);
}

bool in_private_bus() {
  // Tests that change interfaces (down/up, qdiscs) only where the bus is ours alone.
  const char* mode = std::getenv("DUALV_HIL");
  return mode != nullptr && (std::string(mode) == "uml" || std::string(mode) == "netns");
}

int shell(const std::string& cmd) { return std::system(cmd.c_str()); }

bool have_interface(const char* ifname) { return if_nametoindex(ifname) != 0; }

TEST(SocketCanHil, TwoSocketsExchangeFramesWithKernelTimestamps) {
  SocketCanBus a(config("vcan0"));
  SocketCanBus b(config("vcan0"));
  EXPECT_TRUE(a.is_virtual());
  EXPECT_EQ(a.state(), BusStatus::kOk);

  fw::CanFrame remote;
  remote.id = 0x701;
  remote.rtr = true;
  const std::vector<fw::CanFrame> sent = {frame(0x080, {}), frame(0x201, {0x0F, 0x00, 0xE8, 0x03}),
                                          frame(0x1ABCDEF0, {1, 2, 3, 4, 5, 6, 7, 8}, true),
                                          remote};
  const std::uint64_t before = realtime_ns();
  for (const auto& f : sent) {
    ASSERT_EQ(a.send(f), BusStatus::kOk);
  }
  const auto got = collect(b);
  const std::uint64_t after = realtime_ns();
  ASSERT_EQ(got.size(), sent.size());
  std::uint64_t previous = 0;
  for (std::size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(got[i], sent[i]) << "frame " << i;
    EXPECT_GE(got[i].timestamp_ns, before) << "kernel timestamp, CLOCK_REALTIME";
    EXPECT_LE(got[i].timestamp_ns, after);
    EXPECT_GE(got[i].timestamp_ns, previous);
    previous = got[i].timestamp_ns;
  }
  fw::CanFrame none;
  EXPECT_EQ(a.receive(none), BusStatus::kWouldBlock) << "no echo of our own frames";
  EXPECT_EQ(a.counters().tx_frames, sent.size());
  EXPECT_EQ(b.counters().rx_frames, sent.size());
  EXPECT_EQ(b.counters().rx_overruns, 0u);

  // And the other way round.
  ASSERT_EQ(b.send(frame(0x181, {0x37, 0x06, 1, 0, 0, 0})), BusStatus::kOk);
  fw::CanFrame back;
  ASSERT_EQ(a.receive_for(back, kWait), BusStatus::kOk);
  EXPECT_EQ(back, frame(0x181, {0x37, 0x06, 1, 0, 0, 0}));
}

// receive_many until `n` frames came or `quiet` passed without one (bounded, no fixed sleep).
std::vector<fw::CanFrame> collect_many(SocketCanBus& bus, std::size_t n, std::size_t batch,
                                       std::chrono::nanoseconds quiet = kWait) {
  std::vector<fw::CanFrame> out;
  std::vector<fw::CanFrame> buf(batch);
  while (out.size() < n && bus.wait_readable(quiet)) {
    BusStatus s = BusStatus::kOk;
    const std::size_t got = bus.receive_many(buf, s);
    out.insert(out.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(got));
    if (s != BusStatus::kOk && s != BusStatus::kWouldBlock) break;
  }
  return out;
}

TEST(SocketCanHil, SendManyAndReceiveManyKeepOrderContentAndTimestamps) {
  SocketCanBus a(config("vcan0"));
  SocketCanBus b(config("vcan0"));
  std::vector<fw::CanFrame> sent;
  sent.push_back(frame(0x080, {}));
  for (std::uint8_t node = 1; node <= 4; ++node)
    sent.push_back(frame(0x200u + node, {0x0F, 0x00, node, 0x03}));
  sent.push_back(frame(0x77F, {0x05}));
  sent.push_back(frame(0x1ABCDEF0, {1, 2, 3, 4, 5, 6, 7, 8}, true));
  const std::uint64_t before = realtime_ns();
  BusStatus s = BusStatus::kIoError;
  ASSERT_EQ(a.send_many(sent, s), sent.size());
  EXPECT_EQ(s, BusStatus::kOk);
  EXPECT_EQ(a.counters().tx_frames, sent.size());
  // Batches of 3 (fewer than were sent) and of 16 (more): the same frames in order.
  const auto got = collect_many(b, sent.size(), 3);
  const std::uint64_t after = realtime_ns();
  ASSERT_EQ(got.size(), sent.size());
  std::uint64_t previous = 0;
  for (std::size_t i = 0; i < sent.size(); ++i) {
    EXPECT_EQ(got[i], sent[i]) << "frame " << i;
    EXPECT_GE(got[i].timestamp_ns, before) << "kernel timestamp per message, CLOCK_REALTIME";
    EXPECT_LE(got[i].timestamp_ns, after);
    EXPECT_GE(got[i].timestamp_ns, previous);
    previous = got[i].timestamp_ns;
  }
  EXPECT_EQ(b.counters().rx_frames, sent.size());
  std::vector<fw::CanFrame> buf(16);
  EXPECT_EQ(b.receive_many(buf, s), 0u);
  EXPECT_EQ(s, BusStatus::kWouldBlock) << "nothing pending";
}

TEST(SocketCanHil, SendManyStopsAtAFrameItCannotSend) {
  SocketCanBus a(config("vcan0"));
  SocketCanBus b(config("vcan0"));
  fw::CanFrame too_long = frame(0x203, {1, 2, 3, 4, 5, 6, 7, 8});
  too_long.dlc = 9;  // not a classic CAN frame
  const std::vector<fw::CanFrame> batch = {frame(0x201, {1}), frame(0x202, {2}), too_long,
                                           frame(0x204, {4})};
  BusStatus s = BusStatus::kOk;
  EXPECT_EQ(a.send_many(batch, s), 2u);
  EXPECT_EQ(s, BusStatus::kIoError);
  EXPECT_EQ(a.last_errno(), EINVAL);
  EXPECT_EQ(a.counters().tx_frames, 2u);
  EXPECT_EQ(a.counters().tx_dropped, 2u) << "the bad frame and the one after it";
  const auto got = collect_many(b, 3, 16, 300ms);
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0], batch[0]);
  EXPECT_EQ(got[1], batch[1]);
}

TEST(SocketCanHil, SendReceiveAndRestartAllocateNothing) {
  SocketCanBus a(config("vcan0"));
  SocketCanBus b(config("vcan0"));
  const fw::CanFrame sync = frame(0x080, {});
  const fw::CanFrame rpdo = frame(0x201, {1, 2, 3, 4});  // built here: the helper allocates
  const std::array<fw::CanFrame, 2> cycle_frames{sync, rpdo};
  fw::CanFrame f;
  std::array<fw::CanFrame, 8> batch;
  std::size_t received = 0;
  const long before = dualv::test::allocation_count();
  for (int cycle = 0; cycle < 200; ++cycle) {
    (void)a.send(sync);
    (void)a.send(rpdo);
    while (b.receive(f) == BusStatus::kOk) {
      ++received;
    }
    BusStatus s = BusStatus::kOk;
    (void)a.send_many(cycle_frames, s);
    received += b.receive_many(batch, s);
    (void)a.state();
  }
  (void)b.restart();
  const long after = dualv::test::allocation_count();
  EXPECT_EQ(after, before);
  EXPECT_GT(received, 0u);
}

TEST(SocketCanHil, ReceiveFiltersSelectIdsAndFormat) {
  SocketCanBus tx(config("vcan0"));
  // TPDO1 of every node (0x180..0x1FF) and one block of extended ids.
  SocketCanBus rx(
      config("vcan0", {CanFilter{0x180, 0x780, false}, CanFilter{0x1ABCDE00, 0x1FFFFF00, true}}));
  const std::vector<fw::CanFrame> sent = {frame(0x181, {1}),
                                          frame(0x201, {2}),
                                          frame(0x1FF, {3}),
                                          frame(0x012, {4}),
                                          frame(0x1ABCDE12, {5}, true),
                                          frame(0x181, {6}, true),
                                          frame(0x1ABCDF00, {7}, true)};
  for (const auto& f : sent) {
    ASSERT_EQ(tx.send(f), BusStatus::kOk);
  }
  const auto got = collect(rx);
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[0], sent[0]);
  EXPECT_EQ(got[1], sent[2]);
  EXPECT_EQ(got[2], sent[4]);
}

TEST(SocketCanHil, ErrorFramesSetStateAndBusOffLatchesUntilRestart) {
  SocketCanBus a(config("vcan0"));
  SocketCanBus b(config("vcan0"));
  // A plain raw socket (no error frames) that sees the data frames b sees, in the same
  // kernel delivery: once the witness has a frame, b's queue has it too.
  const int witness = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  ASSERT_GE(witness, 0);
  sockaddr_can witness_addr{};
  witness_addr.can_family = AF_CAN;
  witness_addr.can_ifindex = static_cast<int>(if_nametoindex("vcan0"));
  ASSERT_EQ(::bind(witness, reinterpret_cast<sockaddr*>(&witness_addr), sizeof(witness_addr)), 0);
  const timeval witness_timeout{2, 0};
  ASSERT_EQ(
      ::setsockopt(witness, SOL_SOCKET, SO_RCVTIMEO, &witness_timeout, sizeof(witness_timeout)), 0);

  std::array<std::uint8_t, 8> d{};
  d[1] = CAN_ERR_CRTL_TX_PASSIVE;
  d[6] = 128;
  inject_raw("vcan0", CAN_ERR_FLAG | CAN_ERR_CRTL | CAN_ERR_CNT, d);
  ASSERT_EQ(a.send(frame(0x181, {1})), BusStatus::kOk);
  fw::CanFrame f;
  ASSERT_EQ(b.receive_for(f, kWait), BusStatus::kOk);  // the error frame is consumed first
  EXPECT_EQ(f, frame(0x181, {1}));
  EXPECT_EQ(b.state(), BusStatus::kErrorPassive);
  EXPECT_EQ(b.counters().error_passive_events, 1u);
  EXPECT_EQ(b.counters().error_frames, 1u);
  EXPECT_EQ(b.error_stats().tx_error_counter, 128);

  d = {};
  d[1] = CAN_ERR_CRTL_ACTIVE;
  inject_raw("vcan0", CAN_ERR_FLAG | CAN_ERR_CRTL, d);
  inject_raw("vcan0", CAN_ERR_FLAG | CAN_ERR_ACK, {});
  ASSERT_EQ(a.send(frame(0x181, {2})), BusStatus::kOk);
  ASSERT_EQ(b.receive_for(f, kWait), BusStatus::kOk);
  EXPECT_EQ(b.state(), BusStatus::kOk);
  EXPECT_EQ(b.error_stats().no_ack, 1u);

  inject_raw("vcan0", CAN_ERR_FLAG | CAN_ERR_BUSOFF, {});
  ASSERT_EQ(a.send(frame(0x181, {3})), BusStatus::kOk);  // stale once b is off
  EXPECT_EQ(b.receive_for(f, kWait), BusStatus::kBusOff);
  EXPECT_EQ(b.state(), BusStatus::kBusOff);
  EXPECT_EQ(b.counters().bus_off_events, 1u);
  EXPECT_EQ(b.send(frame(0x201, {0})), BusStatus::kBusOff);
  ASSERT_EQ(a.send(frame(0x181, {4})), BusStatus::kOk);  // arrives while latched: stale
  EXPECT_EQ(b.receive(f), BusStatus::kBusOff) << "latched";
  char text[64];
  EXPECT_STREQ(describe(b.error_stats().last, text, sizeof(text)), "bus-off");

  // vcan has no controller: restart() clears the latch and drains the stale frames.
  can_frame seen{};
  do {
    ASSERT_EQ(::read(witness, &seen, sizeof(seen)), static_cast<ssize_t>(sizeof(seen)));
  } while (seen.data[0] != 4);  // frame 4 is in b's queue now, before the drain
  ::close(witness);
  EXPECT_EQ(b.restart(), BusStatus::kOk);
  EXPECT_EQ(b.state(), BusStatus::kOk);
  EXPECT_EQ(b.receive(f), BusStatus::kWouldBlock) << "stale frames must never be processed";
  ASSERT_EQ(a.send(frame(0x181, {5})), BusStatus::kOk);
  ASSERT_EQ(b.receive_for(f, kWait), BusStatus::kOk);
  EXPECT_EQ(f, frame(0x181, {5}));
  EXPECT_EQ(b.send(frame(0x201, {1})), BusStatus::kOk);
  EXPECT_EQ(b.counters().restarts, 1u);
}

TEST(SocketCanHil, FullReceiveBufferCountsOverruns) {
  SocketCanConfig small = config("vcan0");
  small.receive_buffer_bytes = 1;  // the kernel rounds up to its minimum: a few frames
  SocketCanBus rx(small);
  SocketCanBus tx(config("vcan0"));
  constexpr int kBurst = 200;
  for (int i = 0; i < kBurst; ++i) {
    ASSERT_EQ(tx.send(frame(0x181, {static_cast<std::uint8_t>(i)})), BusStatus::kOk);
  }
  std::this_thread::sleep_for(100ms);
  auto got = collect(rx, 100ms);
  ASSERT_LT(got.size(), static_cast<std::size_t>(kBurst));
  // The kernel reports drops with the next frame it queues: send one more.
  ASSERT_EQ(tx.send(frame(0x181, {0xFF})), BusStatus::kOk);
  const auto last = collect(rx, 300ms);
  ASSERT_EQ(last.size(), 1u);
  EXPECT_EQ(got.size() + 1 + rx.counters().rx_overruns, static_cast<std::size_t>(kBurst) + 1);
}

TEST(SocketCanHil, FullTransmitQueueGivesWouldBlockAndIsCounted) {
  if (!in_private_bus()) {
    GTEST_SKIP() << "needs a private vcan1 to plug (DUALV_HIL=uml or netns)";
  }
  if (!have_interface("vcan1")) {
    GTEST_SKIP() << "needs vcan1 (run_in_vcan.sh --vcans 2)";
  }
  // A plug qdisc holds frames until released: with a 3-frame limit (16 bytes each) the
  // 4th send fails with ENOBUFS, as when a controller's transmit queue is full.
  if (shell("tc qdisc replace dev vcan1 root plug limit 48 >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "tc plug qdisc not available (sch_plug)";
  }
  SocketCanBus tx(config("vcan1"));
  SocketCanBus rx(config("vcan1"));
  int ok = 0;
  int blocked = 0;
  for (int i = 0; i < 10; ++i) {
    const BusStatus s = tx.send(frame(0x201, {static_cast<std::uint8_t>(i)}));
    if (s == BusStatus::kOk) ++ok;
    if (s == BusStatus::kWouldBlock) ++blocked;
  }
  // The same full queue for a batch: the frames up to the full queue are sent, then
  // kWouldBlock (ENOBUFS) for the rest.
  std::vector<fw::CanFrame> more;
  for (std::uint8_t i = 0; i < 5; ++i) more.push_back(frame(0x202, {i}));
  BusStatus batch_status = BusStatus::kOk;
  const std::size_t batch_sent = tx.send_many(more, batch_status);
  shell("tc qdisc del dev vcan1 root >/dev/null 2>&1");
  EXPECT_EQ(batch_sent, 0u) << "the plug still holds 3 frames";
  EXPECT_EQ(batch_status, BusStatus::kWouldBlock);
  EXPECT_EQ(ok, 3);
  EXPECT_EQ(blocked, 7);
  EXPECT_EQ(tx.counters().tx_dropped, 7u + 5u);
  EXPECT_EQ(tx.last_errno(), ENOBUFS);
  EXPECT_EQ(tx.state(), BusStatus::kOk) << "a full queue is not a bus fault";
  ASSERT_EQ(tx.send(frame(0x201, {0xAA})), BusStatus::kOk);
  const auto got = collect(rx);
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got.back(), frame(0x201, {0xAA}));
}

TEST(SocketCanHil, FramesFromCansendAreReceived) {
  SocketCanBus rx(config("vcan0"));
  ASSERT_EQ(shell("cansend vcan0 123#DEADBEEF && cansend vcan0 1ABCDEF0#0102 && "
                  "cansend vcan0 321#R && cansend vcan0 080#"),
            0);
  fw::CanFrame remote;
  remote.id = 0x321;
  remote.rtr = true;
  const auto got = collect(rx);
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got[0], frame(0x123, {0xDE, 0xAD, 0xBE, 0xEF}));
  EXPECT_EQ(got[1], frame(0x1ABCDEF0, {0x01, 0x02}, true));
  EXPECT_EQ(got[2], remote);
  EXPECT_EQ(got[3], frame(0x080, {}));
  for (const auto& f : got) {
    EXPECT_NE(f.timestamp_ns, 0u);
  }
}

// candump's log format: "(1700000000.123456) vcan0 123#DEADBEEF".
std::string log_text(const fw::CanFrame& f) {
  char id[16];
  std::snprintf(id, sizeof(id), f.extended ? "%08X" : "%03X", f.id);
  std::string s = std::string(id) + "#";
  if (f.rtr) {
    return s + "R";
  }
  for (std::size_t i = 0; i < f.dlc; ++i) {
    char b[4];
    std::snprintf(b, sizeof(b), "%02X", f.data[i]);
    s += b;
  }
  return s;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(SocketCanHil, CandumpLogOfOurFramesMatches) {
  char path[] = "/tmp/dualv-candump-XXXXXX";
  const int out = mkstemp(path);
  ASSERT_GE(out, 0);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    dup2(out, STDOUT_FILENO);
    execlp("candump", "candump", "-L", "vcan0", static_cast<char*>(nullptr));
    _exit(127);
  }
  close(out);
  SocketCanBus tx(config("vcan0"));
  SocketCanBus rx(config("vcan0"));
  // Wait until candump is listening: send a probe until it shows up in the log.
  const fw::CanFrame probe = frame(0x7EF, {0x55});
  bool ready = false;
  for (int i = 0; i < 100 && !ready; ++i) {
    ASSERT_EQ(tx.send(probe), BusStatus::kOk);
    std::this_thread::sleep_for(50ms);
    ready = read_file(path).find("7EF#55") != std::string::npos;
  }
  ASSERT_TRUE(ready) << "candump never logged the probe";
  (void)collect(rx, 100ms);  // rx saw the probes too

  fw::CanFrame remote;
  remote.id = 0x705;
  remote.rtr = true;
  const std::vector<fw::CanFrame> sent = {frame(0x080, {}), frame(0x201, {0x0F, 0x00, 0x64, 0x00}),
                                          frame(0x12345678, {0xA5}, true), remote,
                                          frame(0x7EE, {0xEE})};
  for (const auto& f : sent) {
    ASSERT_EQ(tx.send(f), BusStatus::kOk);
  }
  const auto received = collect(rx);
  ASSERT_EQ(received.size(), sent.size());
  bool done = false;
  for (int i = 0; i < 100 && !done; ++i) {
    std::this_thread::sleep_for(20ms);
    done = read_file(path).find("7EE#EE") != std::string::npos;
  }
  kill(pid, SIGTERM);
  waitpid(pid, nullptr, 0);
  const std::string log = read_file(path);
  unlink(path);
  ASSERT_TRUE(done) << log;

  // Lines after the last probe are exactly our frames, in order, with the same kernel
  // timestamps our receiver saw (candump logs microseconds).
  std::vector<std::string> lines;
  std::istringstream in(log);
  for (std::string line; std::getline(in, line);) {
    if (line.find("7EF#55") != std::string::npos) {
      lines.clear();
    } else if (!line.empty()) {
      lines.push_back(line);
    }
  }
  ASSERT_EQ(lines.size(), sent.size()) << log;
  for (std::size_t i = 0; i < sent.size(); ++i) {
    unsigned long long sec = 0;
    unsigned long long usec = 0;
    char ifname[IFNAMSIZ] = {};
    char body[64] = {};
    ASSERT_EQ(std::sscanf(lines[i].c_str(), "(%llu.%llu) %15s %63s", &sec, &usec, ifname, body), 4)
        << lines[i];
    EXPECT_STREQ(ifname, "vcan0");
    EXPECT_EQ(std::string(body), log_text(sent[i])) << lines[i];
    const std::uint64_t candump_us = sec * 1'000'000ULL + usec;
    EXPECT_EQ(candump_us, received[i].timestamp_ns / 1000) << lines[i];
  }
}

TEST(SocketCanHil, MissingInterfaceGivesAClearError) {
  try {
    SocketCanBus bus(config("vcan9"));
    FAIL() << "opened a missing interface";
  } catch (const CanSetupError& e) {
    EXPECT_THAT(e.what(), HasSubstr("'vcan9' does not exist"));
    EXPECT_THAT(e.what(), HasSubstr("ip link add dev vcan9 type vcan"));
  }
}

TEST(SocketCanHil, InterfaceDownGivesAClearError) {
  if (!in_private_bus()) {
    GTEST_SKIP() << "would take a shared interface down";
  }
  if (!have_interface("vcan1")) {
    GTEST_SKIP() << "needs vcan1 (run_in_vcan.sh --vcans 2)";
  }
  ASSERT_EQ(shell("ip link set vcan1 down"), 0);
  try {
    SocketCanBus bus(config("vcan1"));
    ADD_FAILURE() << "opened an interface that is down";
  } catch (const CanSetupError& e) {
    EXPECT_THAT(e.what(), HasSubstr("'vcan1' is down"));
    EXPECT_THAT(e.what(), HasSubstr("ip link set vcan1 up"));
  }
  ASSERT_EQ(shell("ip link set vcan1 up"), 0);
}

}  // namespace
}  // namespace dualv::drivers
