// can_capture IFACE FILE [--period-ms N] [--errors]: the HIL tests' capture of a CAN interface,
// written in `candump -l` format ("(seconds.micros) IFACE ID#DATA", ID 3 hex digits or 8 for an
// extended id, "#R" for a remote frame), so check_*_wire.py read it as they read candump's.
//
// Why not candump: candump wakes for every frame (select + recvmsg + a log line each), which in
// the user-mode-linux guest costs about half its one CPU at a few hundred cycles a second
// (tests/hil/README.md "Timing in the guest"), taking it from the loop under test. This tool
// sleeps N ms (default 20) between reads and takes everything pending in batches
// (SocketCanBus::receive_many: recvmmsg), with the kernel's receive timestamps (SO_TIMESTAMPNS),
// so the capture's times are when the frames were on the bus, not when they were read. Its
// receive buffer is 8 MB (SO_RCVBUFFORCE when permitted): a second of the loop's frames.
// Frames lost to a full buffer are counted and reported at exit; a test fails on them.
// --errors: error frames too (as `candump -L 'IFACE,0:0,#FFFFFFFF'` shows them: the id with
// CAN_ERR_FLAG as 8 hex digits, e.g. "20000040#..." for bus-off), read from a second socket that
// takes error frames only; each wake-up's lines are written in the order of their timestamps.
// Exits (status 0; 1 if any frame was lost) on SIGINT/SIGTERM after taking what is pending.
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "drivers/can/socketcan_bus.hpp"

namespace {
volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

std::int64_t now_ns(clockid_t clock) {
  timespec ts{};
  ::clock_gettime(clock, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void write_frame(std::FILE* out, const std::string& ifname, const dualv::fw::CanFrame& f) {
  const unsigned long long s = f.timestamp_ns / 1'000'000'000ULL;
  const unsigned long long us = (f.timestamp_ns % 1'000'000'000ULL) / 1000ULL;
  std::fprintf(out, "(%llu.%06llu) %s ", s, us, ifname.c_str());
  if (f.extended)
    std::fprintf(out, "%08X#", f.id);
  else
    std::fprintf(out, "%03X#", f.id);
  if (f.rtr) {
    std::fputs("R\n", out);
    return;
  }
  for (int i = 0; i < f.dlc; ++i) std::fprintf(out, "%02X", f.data[static_cast<std::size_t>(i)]);
  std::fputc('\n', out);
}
// A raw socket on ifname that receives error frames only (no data frame passes its filter),
// with kernel receive timestamps; -1 on failure (errno set).
int open_error_socket(const std::string& ifname) {
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) return -1;
  const can_err_mask_t err_mask = CAN_ERR_MASK;
  const int on = 1;
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(::if_nametoindex(ifname.c_str()));
  if (addr.can_ifindex == 0 || ::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, nullptr, 0) != 0 ||
      ::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask)) != 0 ||
      ::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof(on)) != 0 ||
      ::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    const int err = errno;
    ::close(fd);
    errno = err;
    return -1;
  }
  return fd;
}

// Appends the error frames pending on fd to out (id: the can_id with CAN_ERR_FLAG, printed as
// an extended id).
void take_error_frames(int fd, std::vector<dualv::fw::CanFrame>& out) {
  for (;;) {
    can_frame cf{};
    iovec iov{&cf, sizeof(cf)};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof(control);
    if (::recvmsg(fd, &msg, MSG_DONTWAIT) != static_cast<ssize_t>(sizeof(cf))) return;
    dualv::fw::CanFrame f;
    f.id = cf.can_id & (CAN_ERR_FLAG | CAN_ERR_MASK);
    f.extended = true;
    f.dlc = std::min<std::uint8_t>(cf.len, CAN_MAX_DLEN);
    std::copy(cf.data, cf.data + f.dlc, f.data.begin());
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
        timespec ts{};
        std::memcpy(&ts, CMSG_DATA(c), sizeof(ts));
        f.timestamp_ns = static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ULL +
                         static_cast<std::uint64_t>(ts.tv_nsec);
      }
    }
    out.push_back(f);
  }
}
}  // namespace

int main(int argc, char** argv) {
  const char* usage = "usage: can_capture IFACE FILE [--period-ms N] [--errors]\n";
  if (argc < 3) {
    std::fputs(usage, stderr);
    return 2;
  }
  const std::string ifname = argv[1];
  long period_ms = 20;
  bool errors = false;
  for (int i = 3; i < argc; ++i) {
    if (std::strcmp(argv[i], "--errors") == 0) {
      errors = true;
    } else if (std::strcmp(argv[i], "--period-ms") == 0 && i + 1 < argc) {
      char* end = nullptr;
      period_ms = std::strtol(argv[++i], &end, 10);
      if (*end != '\0' || period_ms < 1 || period_ms > 100) {
        std::fprintf(stderr, "can_capture: --period-ms %s: 1..100\n", argv[i]);
        return 2;
      }
    } else {
      std::fputs(usage, stderr);
      return 2;
    }
  }
  dualv::drivers::SocketCanConfig cfg;
  cfg.interface = ifname;
  cfg.receive_buffer_bytes = 8 << 20;  // capped by net.core.rmem_max without privilege
  std::unique_ptr<dualv::drivers::SocketCanBus> bus;
  try {
    bus = std::make_unique<dualv::drivers::SocketCanBus>(cfg);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "can_capture: %s\n", e.what());
    return 2;
  }
  const int error_fd = errors ? open_error_socket(ifname) : -1;
  if (errors && error_fd < 0) {
    std::fprintf(stderr, "can_capture: error frames of %s: %s\n", ifname.c_str(),
                 std::strerror(errno));
    return 2;
  }
  const int force = 8 << 20;
  (void)::setsockopt(bus->fd(), SOL_SOCKET, SO_RCVBUFFORCE, &force, sizeof(force));
  std::FILE* out = std::fopen(argv[2], "w");
  if (out == nullptr) {
    std::fprintf(stderr, "can_capture: %s: %s\n", argv[2], std::strerror(errno));
    return 2;
  }
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  std::fprintf(stderr, "can_capture: capturing %s into %s every %ld ms\n", ifname.c_str(), argv[2],
               period_ms);
  // Written out every ~250 ms, not every wake-up: in the guest every write to the host's file
  // system is a system call of its own (tests/hil/README.md "What a cycle costs in the guest");
  // a reader of the file during the run (a test's SYNC count) sees it at most that late.
  const long flush_every = std::max(1L, 250 / period_ms);
  static char buffer[1 << 20];
  std::setvbuf(out, buffer, _IOFBF, sizeof(buffer));
  std::vector<dualv::fw::CanFrame> batch(64);
  std::vector<dualv::fw::CanFrame> pending;
  pending.reserve(1 << 16);
  unsigned long long frames = 0;
  long wakes = 0;
  // What a wake-up's work costs (reading, formatting, writing), reported at exit: in the guest
  // the capture runs above the loop under test (serve_can_hil.sh), and a wire gap the guest's
  // stall probe does not excuse may be the capture's own time.
  std::int64_t longest_ns = 0, longest_at_ns = 0;
  long slow_wakes = 0;  // over 2 ms
  for (;;) {
    const bool last = g_stop != 0;  // one more drain after the signal
    const std::int64_t woke = now_ns(CLOCK_MONOTONIC);
    pending.clear();
    for (;;) {
      dualv::drivers::BusStatus s = dualv::drivers::BusStatus::kOk;
      const std::size_t got = bus->receive_many(batch, s);
      pending.insert(pending.end(), batch.begin(), batch.begin() + static_cast<long>(got));
      if (s != dualv::drivers::BusStatus::kOk) break;
    }
    if (error_fd >= 0) {
      take_error_frames(error_fd, pending);
      std::stable_sort(pending.begin(), pending.end(), [](const auto& a, const auto& b) {
        return a.timestamp_ns < b.timestamp_ns;
      });
    }
    for (const auto& f : pending) write_frame(out, ifname, f);
    frames += pending.size();
    if (++wakes % flush_every == 0 || last) std::fflush(out);
    const std::int64_t took = now_ns(CLOCK_MONOTONIC) - woke;
    slow_wakes += took > 2'000'000 ? 1 : 0;
    if (took > longest_ns) {
      longest_ns = took;
      longest_at_ns = now_ns(CLOCK_REALTIME) - took;
    }
    if (last) break;
    const timespec ts{0, period_ms * 1'000'000L};
    nanosleep(&ts, nullptr);  // a signal ends it early
  }
  std::fclose(out);
  if (error_fd >= 0) ::close(error_fd);
  const unsigned long long lost = bus->counters().rx_overruns;
  std::fprintf(stderr,
               "can_capture: %ld wake-ups, %ld of them over 2 ms; the longest %.1f ms from "
               "(%.6f)\n",
               wakes, slow_wakes, static_cast<double>(longest_ns) * 1e-6,
               static_cast<double>(longest_at_ns) * 1e-9);
  std::fprintf(stderr, "can_capture: %llu frames, %llu lost (receive buffer full)\n", frames, lost);
  return lost == 0 ? 0 : 1;
}
