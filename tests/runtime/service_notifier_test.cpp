// ServiceNotifier: what it tells systemd, and that its watchdog pings only while something
// calls beat() (the control loop once per cycle, the idle --serve loop once per poll).
// One test goes through libsystemd's sd_notify to a real AF_UNIX datagram socket.
#include "runtime/service_notifier.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace dualv::runtime {
namespace {

using namespace std::chrono_literals;

// Collects the notifications in order (the sink is called from two threads).
struct Recorder {
  std::mutex mutex;
  std::vector<std::string> messages;
  ServiceNotifier::Sink sink() {
    return [this](const std::string& m) {
      std::lock_guard<std::mutex> lock(mutex);
      messages.push_back(m);
    };
  }
  int count(const std::string& m) {
    std::lock_guard<std::mutex> lock(mutex);
    int n = 0;
    for (const auto& x : messages) n += x == m;
    return n;
  }
  std::vector<std::string> all() {
    std::lock_guard<std::mutex> lock(mutex);
    return messages;
  }
};

// Calls beat() every millisecond, like a 1 kHz loop, until stopped.
struct BeatingLoop {
  explicit BeatingLoop(ServiceNotifier& n)
      : thread([this, &n] {
          while (!stop) {
            n.beat();
            std::this_thread::sleep_for(1ms);
          }
        }) {}
  ~BeatingLoop() { halt(); }
  void halt() {
    stop = true;
    if (thread.joinable()) thread.join();
  }
  std::atomic<bool> stop{false};
  std::thread thread;
};

TEST(ServiceNotifier, ReadyStatusAndStoppingAreSentInOrder) {
  Recorder rec;
  ServiceNotifier n(0us, rec.sink());  // no watchdog
  n.ready("waiting for start");
  n.status("running paper.yaml\n(key lab1)");  // a newline would start a new field
  n.stopping("stopping: signal received");
  const std::vector<std::string> expected = {"READY=1\nSTATUS=waiting for start",
                                             "STATUS=running paper.yaml (key lab1)",
                                             "STOPPING=1\nSTATUS=stopping: signal received"};
  EXPECT_EQ(rec.all(), expected);
  EXPECT_EQ(n.pings(), 0u);
}

TEST(ServiceNotifier, PingsWhileTheLoopBeatsAndStopsWhenItHangs) {
  Recorder rec;
  ServiceNotifier n(40ms, rec.sink());  // checks every 10 ms
  n.beat();
  std::this_thread::sleep_for(50ms);
  EXPECT_EQ(n.pings(), 0u) << "pinged before READY=1";
  BeatingLoop loop(n);
  n.ready("running");
  std::this_thread::sleep_for(300ms);
  const std::uint64_t while_beating = n.pings();
  // One at READY=1 and then about one per 10 ms; a loaded machine may skip some.
  EXPECT_GE(while_beating, 5u);

  loop.halt();                        // the loop hangs: no more beats
  std::this_thread::sleep_for(30ms);  // a ping for beats just before the halt may follow
  const std::uint64_t after_hang = n.pings();
  std::this_thread::sleep_for(300ms);  // 30 checks without a beat
  EXPECT_EQ(n.pings(), after_hang) << "pinged for a loop that no longer runs";
  EXPECT_EQ(rec.count("WATCHDOG=1"), static_cast<int>(n.pings()));

  n.beat();  // the loop is back: pinging resumes
  for (int i = 0; i < 200 && n.pings() == after_hang; ++i) std::this_thread::sleep_for(5ms);
  EXPECT_EQ(n.pings(), after_hang + 1);
}

TEST(ServiceNotifier, NoPingsAfterStopping) {
  Recorder rec;
  ServiceNotifier n(40ms, rec.sink());
  BeatingLoop loop(n);
  n.ready("running");
  std::this_thread::sleep_for(50ms);
  n.stopping("finished");
  const std::uint64_t at_stop = n.pings();
  EXPECT_GE(at_stop, 1u);
  std::this_thread::sleep_for(100ms);  // the loop keeps beating
  EXPECT_EQ(n.pings(), at_stop);
  EXPECT_EQ(rec.all().back(), "STOPPING=1\nSTATUS=finished");
}

// The default constructor reads NOTIFY_SOCKET and WATCHDOG_USEC as systemd sets them, and
// sd_notify delivers to a real unix datagram socket.
TEST(ServiceNotifier, TalksToTheNotifySocketFromTheEnvironment) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("dualv-notify-" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "notify.sock").string();
  const int fd = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  ASSERT_LT(path.size(), sizeof addr.sun_path);
  std::copy(path.begin(), path.end(), addr.sun_path);
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  timeval tv{2, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);

  setenv("NOTIFY_SOCKET", path.c_str(), 1);
  setenv("WATCHDOG_USEC", "200000", 1);
  setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  std::vector<std::string> got;
  {
    ServiceNotifier n;
    EXPECT_EQ(n.watchdog_interval(), 200ms);
    n.beat();
    n.ready("waiting for start");
    char buf[512];
    while (got.size() < 2) {
      const ssize_t r = recv(fd, buf, sizeof buf, 0);
      ASSERT_GT(r, 0) << "nothing on the notify socket";
      got.emplace_back(buf, static_cast<std::size_t>(r));
    }
    n.stopping("bye");
    const ssize_t r = recv(fd, buf, sizeof buf, 0);
    ASSERT_GT(r, 0);
    got.emplace_back(buf, static_cast<std::size_t>(r));
  }
  unsetenv("NOTIFY_SOCKET");
  unsetenv("WATCHDOG_USEC");
  unsetenv("WATCHDOG_PID");
  close(fd);
  std::filesystem::remove_all(dir);
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[0], "READY=1\nSTATUS=waiting for start");
  EXPECT_EQ(got[1], "WATCHDOG=1");
  EXPECT_EQ(got[2], "STOPPING=1\nSTATUS=bye");

  // Another process's watchdog (WATCHDOG_PID not ours) is not ours to feed.
  setenv("WATCHDOG_USEC", "200000", 1);
  setenv("WATCHDOG_PID", "1", 1);
  EXPECT_EQ(ServiceNotifier().watchdog_interval(), 0us);
  unsetenv("WATCHDOG_USEC");
  unsetenv("WATCHDOG_PID");
}

}  // namespace
}  // namespace dualv::runtime
