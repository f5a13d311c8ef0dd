// can_capture IFACE FILE [--period-ms N]: the HIL tests' capture of a CAN interface, written
// in `candump -l` format ("(seconds.micros) IFACE ID#DATA", ID 3 hex digits or 8 for an
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
// Exits (status 0; 1 if any frame was lost) on SIGINT/SIGTERM after taking what is pending.
#include <sys/socket.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
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
}  // namespace

int main(int argc, char** argv) {
  if (argc != 3 && !(argc == 5 && std::strcmp(argv[3], "--period-ms") == 0)) {
    std::fprintf(stderr, "usage: can_capture IFACE FILE [--period-ms N]\n");
    return 2;
  }
  const std::string ifname = argv[1];
  const long period_ms = argc == 5 ? std::strtol(argv[4], nullptr, 10) : 20;
  if (period_ms < 1 || period_ms > 100) {
    std::fprintf(stderr, "can_capture: --period-ms %s: 1..100\n", argv[4]);
    return 2;
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
  unsigned long long frames = 0;
  long wakes = 0;
  for (;;) {
    const bool last = g_stop != 0;  // one more drain after the signal
    for (;;) {
      dualv::drivers::BusStatus s = dualv::drivers::BusStatus::kOk;
      const std::size_t got = bus->receive_many(batch, s);
      for (std::size_t k = 0; k < got; ++k) write_frame(out, ifname, batch[k]);
      frames += got;
      if (s != dualv::drivers::BusStatus::kOk) break;
    }
    if (++wakes % flush_every == 0 || last) std::fflush(out);
    if (last) break;
    const timespec ts{0, period_ms * 1'000'000L};
    nanosleep(&ts, nullptr);  // a signal ends it early
  }
  std::fclose(out);
  const unsigned long long lost = bus->counters().rx_overruns;
  std::fprintf(stderr, "can_capture: %llu frames, %llu lost (receive buffer full)\n", frames, lost);
  return lost == 0 ? 0 : 1;
}
