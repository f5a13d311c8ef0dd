// can_fault_gateway: a test-only CAN "cable" between two SocketCAN interfaces that forwards
// every frame both ways and breaks the frames of chosen COB-IDs on purpose, so the safety
// HIL test (safety_hil.sh) can drop, delay and corrupt frames on real SocketCAN. The
// controller sits on one side (vcan0), the drive emulator on the other (vcan1); a COB-ID
// names the direction by itself (TPDOs come from the drives, RPDOs from the master).
//
//   can_fault_gateway vcan0 vcan1 [--rule "ACTION COB [from=S] [count=N] [ARG=V]"]...
//
//   drop COB                 the frame is lost
//   delay COB ms=D           the frame arrives D ms late (later frames may overtake it)
//   dlc COB dlc=L            the frame arrives with data length L (a wrong DLC)
//   xor COB mask=M           every data byte arrives XORed with M
//
// from=S: the rule acts from S seconds after the master first enabled a drive (the first
// RPDO1, 201h..27Fh, whose controlword says "enable operation"), so "from" counts from the
// start of the program whatever the boot and priming took (default 0). Until then no rule
// acts.
// count=N: it acts on N frames, then stops (default 0: for good).
//
// Error frames are not forwarded: a controller's bus-off is its own, not the other side's.
// Prints "ready" once both sockets are open, a line when a rule first acts, and a count per
// rule on SIGINT/SIGTERM (the test checks the rule really acted). Exit status 2 on bad
// usage or when an interface cannot be opened. Not real-time code: a test tool, which the
// test runs at SCHED_FIFO (chrt) so it never delays frames it was not asked to delay.
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <deque>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

using Clock = std::chrono::steady_clock;

enum class Action { kDrop, kDelay, kDlc, kXor };

struct Rule {
  std::string text;
  Action action = Action::kDrop;
  std::uint32_t cob = 0;
  double from_s = 0.0;
  std::uint64_t count = 0;  // 0: for good
  double delay_ms = 0.0;
  std::uint8_t dlc = 0;
  std::uint8_t mask = 0;
  std::uint64_t acted = 0;
};

std::uint32_t parse_uint(const std::string& s, const std::string& what) {
  std::size_t used = 0;
  unsigned long v = 0;
  try {
    v = std::stoul(s, &used, 0);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != s.size()) throw std::invalid_argument(what + ": '" + s + "' is not a number");
  return static_cast<std::uint32_t>(v);
}

double parse_double(const std::string& s, const std::string& what) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(s, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != s.size() || v < 0.0)
    throw std::invalid_argument(what + ": '" + s + "' is not a non-negative number");
  return v;
}

Rule parse_rule(const std::string& text) {
  std::istringstream in(text);
  std::string action, cob;
  in >> action >> cob;
  Rule r;
  r.text = text;
  if (action == "drop")
    r.action = Action::kDrop;
  else if (action == "delay")
    r.action = Action::kDelay;
  else if (action == "dlc")
    r.action = Action::kDlc;
  else if (action == "xor")
    r.action = Action::kXor;
  else
    throw std::invalid_argument("rule '" + text + "': action must be drop, delay, dlc or xor");
  if (cob.empty()) throw std::invalid_argument("rule '" + text + "': no COB-ID");
  r.cob = parse_uint(cob, "rule '" + text + "' COB-ID");
  if (r.cob > CAN_SFF_MASK) throw std::invalid_argument("rule '" + text + "': COB-ID above 7FFh");
  bool has_arg = r.action == Action::kDrop;
  for (std::string kv; in >> kv;) {
    const std::size_t eq = kv.find('=');
    if (eq == std::string::npos) throw std::invalid_argument("rule '" + text + "': '" + kv + "'");
    const std::string k = kv.substr(0, eq), v = kv.substr(eq + 1),
                      what = "rule '" + text + "' " + k;
    if (k == "from") {
      r.from_s = parse_double(v, what);
    } else if (k == "count") {
      r.count = parse_uint(v, what);
    } else if (k == "ms" && r.action == Action::kDelay) {
      r.delay_ms = parse_double(v, what);
      has_arg = true;
    } else if (k == "dlc" && r.action == Action::kDlc) {
      r.dlc = static_cast<std::uint8_t>(parse_uint(v, what));
      if (r.dlc > CAN_MAX_DLEN) throw std::invalid_argument(what + ": at most 8");
      has_arg = true;
    } else if (k == "mask" && r.action == Action::kXor) {
      const std::uint32_t m = parse_uint(v, what);
      if (m == 0 || m > 0xFF) throw std::invalid_argument(what + ": 1..0xFF");
      r.mask = static_cast<std::uint8_t>(m);
      has_arg = true;
    } else {
      throw std::invalid_argument("rule '" + text + "': unknown key '" + k + "'");
    }
  }
  if (!has_arg)
    throw std::invalid_argument("rule '" + text +
                                "': needs ms= (delay), dlc= (dlc) or mask= (xor)");
  return r;
}

int open_raw(const std::string& ifname) {
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) throw std::runtime_error("CAN_RAW socket: " + std::string(std::strerror(errno)));
  const unsigned idx = ::if_nametoindex(ifname.c_str());
  if (idx == 0) {
    ::close(fd);
    throw std::runtime_error("interface '" + ifname +
                             "' does not exist (run through tests/hil/run_in_vcan.sh --vcans 2)");
  }
  // Large buffers: a burst held back by a delay rule must not overflow either side.
  const int buf = 1 << 20;
  ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &buf, sizeof(buf));
  ::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &buf, sizeof(buf));
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(idx);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    const int err = errno;
    ::close(fd);
    throw std::runtime_error("bind to '" + ifname + "': " + std::strerror(err));
  }
  return fd;
}

struct Held {
  Clock::time_point release;
  can_frame frame;
  int out_fd;
};

constexpr std::size_t kBatch = 64;

struct Stats {
  std::uint64_t forwarded = 0;
  std::uint64_t send_failures = 0;
};

// Sends frames in order with one sendmmsg per try (a frame per call would be a system call
// per frame: in the user-mode-linux guest each costs ~0.05-0.1 ms, tests/hil/README.md "What a
// cycle costs in the guest", and forwarding a 1 kHz cycle's ~14 frames one by one took more than
// the cycle). A full queue is retried: it drains in microseconds on vcan.
void send_frames(int fd, can_frame* frames, std::size_t count, Stats& st) {
  std::size_t done = 0;
  for (int tries = 0; tries < 100 && done < count; ++tries) {
    mmsghdr msgs[kBatch]{};
    iovec iov[kBatch]{};
    const std::size_t n = std::min(count - done, kBatch);
    for (std::size_t i = 0; i < n; ++i) {
      iov[i] = {&frames[done + i], sizeof(can_frame)};
      msgs[i].msg_hdr.msg_iov = &iov[i];
      msgs[i].msg_hdr.msg_iovlen = 1;
    }
    const int r = ::sendmmsg(fd, msgs, static_cast<unsigned>(n), 0);
    if (r > 0) {
      done += static_cast<std::size_t>(r);
      st.forwarded += static_cast<std::uint64_t>(r);
      tries = -1;  // progress: the retries count again
      continue;
    }
    if (r < 0 && errno != ENOBUFS && errno != EAGAIN) break;
    ::usleep(100);
  }
  st.send_failures += count - done;
}

// Reads what is queued on fd (at most kBatch frames) with one recvmmsg.
std::size_t receive_frames(int fd, can_frame* frames) {
  mmsghdr msgs[kBatch]{};
  iovec iov[kBatch]{};
  for (std::size_t i = 0; i < kBatch; ++i) {
    iov[i] = {&frames[i], sizeof(can_frame)};
    msgs[i].msg_hdr.msg_iov = &iov[i];
    msgs[i].msg_hdr.msg_iovlen = 1;
  }
  const int r = ::recvmmsg(fd, msgs, kBatch, MSG_DONTWAIT, nullptr);
  if (r <= 0) return 0;
  std::size_t n = 0;  // whole frames only, in order
  for (int i = 0; i < r; ++i)
    if (msgs[i].msg_len == sizeof(can_frame)) frames[n++] = frames[i];
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  std::string side_a, side_b;
  std::vector<Rule> rules;
  try {
    for (std::size_t i = 0; i < args.size(); ++i) {
      if (args[i] == "--rule" && i + 1 < args.size()) {
        rules.push_back(parse_rule(args[++i]));
      } else if (args[i] == "--help" || args[i] == "-h" || args[i].rfind("--", 0) == 0) {
        throw std::invalid_argument("usage: can_fault_gateway IFACE_A IFACE_B [--rule RULE]...");
      } else if (side_a.empty()) {
        side_a = args[i];
      } else if (side_b.empty()) {
        side_b = args[i];
      } else {
        throw std::invalid_argument("unexpected argument '" + args[i] + "'");
      }
    }
    if (side_b.empty())
      throw std::invalid_argument("usage: can_fault_gateway IFACE_A IFACE_B [--rule RULE]...");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "can_fault_gateway: %s\n", e.what());
    return 2;
  }
  int fd[2] = {-1, -1};
  try {
    fd[0] = open_raw(side_a);
    fd[1] = open_raw(side_b);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "can_fault_gateway: %s\n", e.what());
    return 2;
  }
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  std::printf("can_fault_gateway: %s <-> %s, %zu rule(s); ready\n", side_a.c_str(), side_b.c_str(),
              rules.size());
  for (const Rule& r : rules) std::printf("can_fault_gateway: rule '%s'\n", r.text.c_str());
  std::fflush(stdout);

  const Clock::time_point t0 = Clock::now();
  auto secs = [&](Clock::time_point t) { return std::chrono::duration<double>(t - t0).count(); };
  bool started = false;
  Clock::time_point start{};
  std::deque<Held> held;
  Stats stats;
  while (g_stop == 0) {
    int timeout_ms = 100;
    const Clock::time_point now = held.empty() ? Clock::time_point{} : Clock::now();
    for (const Held& h : held) {
      const auto left = std::chrono::ceil<std::chrono::milliseconds>(h.release - now).count();
      timeout_ms = std::max(0, std::min<int>(timeout_ms, static_cast<int>(left)));
    }
    pollfd p[2] = {{fd[0], POLLIN, 0}, {fd[1], POLLIN, 0}};
    const int n = ::poll(p, 2, timeout_ms);
    if (n < 0 && errno != EINTR) {
      std::perror("can_fault_gateway: poll");
      break;
    }
    for (int side = 0; side < 2 && n > 0; ++side) {
      if ((p[side].revents & POLLIN) == 0) continue;
      const int out = fd[1 - side];
      can_frame in[kBatch];
      can_frame pass[kBatch];
      for (std::size_t got; (got = receive_frames(fd[side], in)) > 0;) {
        // One clock read per batch: a batch is one sender's burst (a cycle's frames).
        const Clock::time_point at = Clock::now();
        std::size_t passing = 0;
        for (std::size_t k = 0; k < got; ++k) {
          can_frame& f = in[k];
          if ((f.can_id & CAN_ERR_FLAG) != 0) continue;
          const std::uint32_t id = f.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_SFF_MASK);
          if (!started && id >= 0x201 && id <= 0x27F && f.len >= 2 && (f.data[0] & 0x0F) == 0x0F) {
            started = true;
            start = at;
            std::printf("can_fault_gateway: t=%.3fs first enable operation (%03X)\n", secs(at), id);
            std::fflush(stdout);
          }
          bool drop = false;
          Clock::time_point release = at;
          for (Rule& r : rules) {
            if ((f.can_id & (CAN_EFF_FLAG | CAN_SFF_MASK)) != r.cob) continue;
            if (!started || std::chrono::duration<double>(at - start).count() < r.from_s) continue;
            if (r.count != 0 && r.acted >= r.count) continue;
            if (r.acted++ == 0) {
              std::printf("can_fault_gateway: t=%.3fs rule '%s' acts\n", secs(at), r.text.c_str());
              std::fflush(stdout);
            }
            switch (r.action) {
              case Action::kDrop:
                drop = true;
                break;
              case Action::kDelay:
                release = at + std::chrono::duration_cast<Clock::duration>(
                                   std::chrono::duration<double, std::milli>(r.delay_ms));
                break;
              case Action::kDlc:
                // The bytes beyond the real length are zero: only the length is wrong.
                f.len = r.dlc;
                break;
              case Action::kXor:
                for (int b = 0; b < f.len; ++b) f.data[b] ^= r.mask;
                break;
            }
          }
          if (drop) continue;
          if (release > at)
            held.push_back({release, f, out});
          else
            pass[passing++] = f;
        }
        send_frames(out, pass, passing, stats);
        if (got < kBatch) break;
      }
    }
    if (held.empty()) continue;
    const Clock::time_point t = Clock::now();
    for (auto it = held.begin(); it != held.end();) {
      if (it->release <= t) {
        send_frames(it->out_fd, &it->frame, 1, stats);
        it = held.erase(it);
      } else {
        ++it;
      }
    }
  }
  std::printf("can_fault_gateway: stopped, %llu frames forwarded, %llu send failures, %zu held\n",
              static_cast<unsigned long long>(stats.forwarded),
              static_cast<unsigned long long>(stats.send_failures), held.size());
  for (const Rule& r : rules)
    std::printf("can_fault_gateway: rule '%s' acted on %llu frames\n", r.text.c_str(),
                static_cast<unsigned long long>(r.acted));
  std::fflush(stdout);
  ::close(fd[0]);
  ::close(fd[1]);
  return 0;
}
