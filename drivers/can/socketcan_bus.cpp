#include "drivers/can/socketcan_bus.hpp"

#include "drivers/can/kernel_frame.hpp"

#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <net/if_arp.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>

namespace dualv::drivers {
namespace {

std::string errno_text(int err) { return std::string(std::strerror(err)); }

std::string create_hint(const std::string& ifname) {
  return "create it with `ip link add dev " + ifname + " type vcan && ip link set " + ifname +
         " up` (virtual bus, needs root), or for a real controller check its driver and run "
         "`ip link set " +
         ifname +
         " up type can bitrate 1000000 restart-ms 100`; on a build machine whose kernel has no "
         "CAN support run the command through tests/hil/run_in_vcan.sh (user-mode-linux)";
}

// A network device without a parent device lives under /sys/devices/virtual: vcan, vxcan.
// Real controllers (USB, PCI, SPI, platform) have a parent. Without sysfs we assume a
// real controller, the conservative choice for restart().
bool sysfs_says_virtual(const std::string& ifname) {
  const std::string link = "/sys/class/net/" + ifname;
  char target[PATH_MAX] = {};
  const ssize_t n = ::readlink(link.c_str(), target, sizeof(target) - 1);
  if (n <= 0) {
    return false;
  }
  return std::string(target, static_cast<std::size_t>(n)).find("/virtual/") != std::string::npos;
}

void set_option(int fd, int level, int name, const void* value, socklen_t size,
                const std::string& ifname, const char* what) {
  if (::setsockopt(fd, level, name, value, size) != 0) {
    const int err = errno;
    ::close(fd);
    throw CanSetupError("CAN interface '" + ifname + "': cannot set " + what + ": " +
                        errno_text(err));
  }
}

}  // namespace

SocketCanBus::SocketCanBus(const SocketCanConfig& config) : interface_(config.interface) {
  const std::string& ifname = interface_;
  if (ifname.empty() || ifname.size() >= IFNAMSIZ) {
    throw CanSetupError("CAN interface name '" + ifname + "' is empty or longer than " +
                        std::to_string(IFNAMSIZ - 1) + " characters");
  }
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  const int socket_errno = fd < 0 ? errno : 0;
  const unsigned ifindex = ::if_nametoindex(ifname.c_str());
  if (ifindex == 0) {
    if (fd >= 0) {
      ::close(fd);
    }
    std::string msg = "CAN interface '" + ifname + "' does not exist: " + create_hint(ifname);
    if (fd < 0) {
      msg += " (this kernel also refuses CAN sockets: " + errno_text(socket_errno) + ")";
    }
    throw CanSetupError(msg);
  }
  if (fd < 0) {
    throw CanSetupError("CAN interface '" + ifname + "': cannot open a CAN_RAW socket (" +
                        errno_text(socket_errno) +
                        "): the kernel needs SocketCAN (CONFIG_CAN, modules can and can-raw: "
                        "`modprobe can-raw`); on a build machine without it run through "
                        "tests/hil/run_in_vcan.sh (user-mode-linux)");
  }

  ifreq ifr{};
  std::memcpy(ifr.ifr_name, ifname.c_str(), ifname.size() + 1);
  if (::ioctl(fd, SIOCGIFHWADDR, &ifr) == 0 && ifr.ifr_hwaddr.sa_family != ARPHRD_CAN) {
    ::close(fd);
    throw CanSetupError("interface '" + ifname + "' exists but is not a CAN interface");
  }
  std::memset(&ifr, 0, sizeof(ifr));
  std::memcpy(ifr.ifr_name, ifname.c_str(), ifname.size() + 1);
  if (::ioctl(fd, SIOCGIFFLAGS, &ifr) == 0 && (ifr.ifr_flags & IFF_UP) == 0) {
    ::close(fd);
    throw CanSetupError("CAN interface '" + ifname + "' is down: bring it up with `ip link set " +
                        ifname + " up` (a real controller also needs `type can bitrate ...`)");
  }

  const int on_fd = 1;
  if (!config.filters.empty()) {
    std::vector<can_filter> filters;
    filters.reserve(config.filters.size());
    for (const CanFilter& f : config.filters) {
      can_filter k{};
      // CAN_EFF_FLAG in the mask makes the kernel compare the frame format too; RTR is
      // left out of the mask so remote frames pass like data frames.
      if (f.extended) {
        k.can_id = (f.id & CAN_EFF_MASK) | CAN_EFF_FLAG;
        k.can_mask = (f.mask & CAN_EFF_MASK) | CAN_EFF_FLAG;
      } else {
        k.can_id = f.id & CAN_SFF_MASK;
        k.can_mask = (f.mask & CAN_SFF_MASK) | CAN_EFF_FLAG;
      }
      filters.push_back(k);
    }
    set_option(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
               static_cast<socklen_t>(filters.size() * sizeof(can_filter)), ifname,
               "receive filters (CAN_RAW_FILTER)");
  }
  if (config.fd_frames) {
    std::memset(&ifr, 0, sizeof(ifr));
    std::memcpy(ifr.ifr_name, ifname.c_str(), ifname.size() + 1);
    if (::ioctl(fd, SIOCGIFMTU, &ifr) == 0 && ifr.ifr_mtu != static_cast<int>(CANFD_MTU)) {
      const int mtu = ifr.ifr_mtu;
      ::close(fd);
      throw CanSetupError("CAN interface '" + ifname + "' does not carry CAN FD frames (MTU " +
                          std::to_string(mtu) + ", CAN FD needs " + std::to_string(CANFD_MTU) +
                          ") but can.bus_layout is fd: for vcan run `ip link set " + ifname +
                          " mtu 72`, for a controller `ip link set " + ifname +
                          " up type can bitrate 1000000 dbitrate 5000000 fd on` (can.bitrate, "
                          "can.fd.data_bitrate), or use can.bus_layout: per_drive or broadcast");
    }
    set_option(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on_fd, sizeof(on_fd), ifname,
               "CAN FD frames (CAN_RAW_FD_FRAMES)");
  }
  const can_err_mask_t err_mask = CAN_ERR_MASK;
  set_option(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask), ifname,
             "error frame filter (CAN_RAW_ERR_FILTER)");
  const int on = 1;
  set_option(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof(on), ifname,
             "receive timestamps (SO_TIMESTAMPNS)");
  set_option(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof(on), ifname, "drop counter (SO_RXQ_OVFL)");
  if (config.receive_buffer_bytes > 0) {
    set_option(fd, SOL_SOCKET, SO_RCVBUF, &config.receive_buffer_bytes, sizeof(int), ifname,
               "receive buffer size (SO_RCVBUF)");
  }
  if (config.send_buffer_bytes > 0) {
    set_option(fd, SOL_SOCKET, SO_SNDBUF, &config.send_buffer_bytes, sizeof(int), ifname,
               "send buffer size (SO_SNDBUF)");
  }

  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(ifindex);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    const int err = errno;
    ::close(fd);
    throw CanSetupError("CAN interface '" + ifname + "': bind failed: " + errno_text(err));
  }
  fd_ = fd;
  fd_frames_ = config.fd_frames;
  virtual_ = sysfs_says_virtual(ifname);
}

SocketCanBus::~SocketCanBus() {
  if (fd_ >= 0) {
    ::close(fd_);
  }
}

namespace {
// Frames per sendmmsg/recvmmsg call: a cycle's frames (4 drives: SYNC, 4 RPDOs, a heartbeat;
// 4 TPDOs back) fit in one.
constexpr std::size_t kBatch = 16;
}  // namespace
static_assert(CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t)) <=
              SocketCanBus::kControlBytes);

BusStatus SocketCanBus::send(const fw::CanFrame& frame) noexcept {
  BusStatus status = BusStatus::kOk;
  (void)send_many(std::span(&frame, 1), status);
  return status;
}

std::size_t SocketCanBus::send_many(std::span<const fw::CanFrame> frames,
                                    BusStatus& status) noexcept {
  status = BusStatus::kOk;
  if (fd_ < 0) {
    status = BusStatus::kClosed;
    return 0;
  }
  if (bus_off_) {
    counters_.tx_dropped += frames.size();
    status = BusStatus::kBusOff;
    return 0;
  }
  std::size_t sent = 0;
  while (sent < frames.size()) {
    std::array<canfd_frame, kBatch> kf;
    std::array<iovec, kBatch> iov{};
    std::array<mmsghdr, kBatch> msgs{};
    std::size_t n = 0;
    for (; n < kBatch && sent + n < frames.size(); ++n) {
      const std::size_t size = to_kernel(frames[sent + n], fd_frames_, kf[n]);
      if (size == 0) break;
      iov[n] = iovec{&kf[n], size};
      msgs[n].msg_hdr.msg_iov = &iov[n];
      msgs[n].msg_hdr.msg_iovlen = 1;
    }
    if (n == 0) {  // frames[sent] cannot be sent on this socket (invalid, or FD without FD)
      counters_.tx_dropped += frames.size() - sent;
      last_errno_ = EINVAL;
      status = BusStatus::kIoError;
      return sent;
    }
    const int r = ::sendmmsg(fd_, msgs.data(), static_cast<unsigned>(n), MSG_DONTWAIT);
    if (r < 0) {
      last_errno_ = errno;
      counters_.tx_dropped += frames.size() - sent;
      status = (last_errno_ == ENOBUFS || last_errno_ == EAGAIN) ? BusStatus::kWouldBlock
                                                                 : BusStatus::kIoError;
      return sent;
    }
    // A short count: the next call reports why the rest could not be queued.
    sent += static_cast<std::size_t>(r);
    counters_.tx_frames += static_cast<std::size_t>(r);
  }
  return sent;
}

SocketCanBus::Read SocketCanBus::read_one(fw::CanFrame& frame) noexcept {
  canfd_frame cf{};
  iovec iov{&cf, sizeof(cf)};
  // Room for the timestamp and the drop counter; on the stack, nothing allocated.
  alignas(cmsghdr) unsigned char control[kControlBytes];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof(control);
  const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
  if (n < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK) {
      return Read::kNone;
    }
    last_errno_ = errno;
    return Read::kFailed;
  }
  return take(cf, msg, static_cast<std::size_t>(n), frame);
}

SocketCanBus::Read SocketCanBus::take(const canfd_frame& cf, msghdr& msg, std::size_t bytes,
                                      fw::CanFrame& frame) noexcept {
  if (bytes != CAN_MTU && bytes != CANFD_MTU) {
    last_errno_ = EPROTO;  // neither a classic nor an FD frame
    return Read::kFailed;
  }
  std::uint64_t stamp = 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level != SOL_SOCKET) {
      continue;
    }
    if (c->cmsg_type == SCM_TIMESTAMPNS) {
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof(ts));
      stamp = static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ULL +
              static_cast<std::uint64_t>(ts.tv_nsec);
    } else if (c->cmsg_type == SO_RXQ_OVFL) {
      std::uint32_t drops = 0;
      std::memcpy(&drops, CMSG_DATA(c), sizeof(drops));
      // Cumulative per socket; unsigned subtraction handles wrap-around.
      counters_.rx_overruns += static_cast<std::uint32_t>(drops - last_drop_count_);
      last_drop_count_ = drops;
    }
  }
  if ((cf.can_id & CAN_ERR_FLAG) != 0) {
    std::array<std::uint8_t, 8> data{};
    std::memcpy(data.data(), cf.data, data.size());
    on_error_frame(cf.can_id, data);
    return Read::kErrorFrame;
  }
  from_kernel(cf, static_cast<ssize_t>(bytes), frame);
  frame.timestamp_ns = stamp;
  return Read::kFrame;
}

void SocketCanBus::on_error_frame(std::uint32_t can_id,
                                  const std::array<std::uint8_t, 8>& data) noexcept {
  const CanErrorReport r = decode_can_error(can_id, data);
  ++counters_.error_frames;
  errors_.last = r;
  if (r.warning) ++errors_.warnings;
  if (r.no_ack) ++errors_.no_ack;
  if (r.protocol) ++errors_.protocol;
  if (r.lost_arbitration) ++errors_.lost_arbitration;
  if (r.rx_overflow || r.tx_overflow) ++errors_.controller_overflows;
  if (r.transceiver) ++errors_.transceiver;
  if (r.tx_timeout) ++errors_.tx_timeouts;
  if (r.bus_error) ++errors_.bus_errors;
  if (r.has_counters) {
    errors_.tx_error_counter = r.tx_error_counter;
    errors_.rx_error_counter = r.rx_error_counter;
  }
  if (r.error_passive) {
    if (!error_passive_) {
      ++counters_.error_passive_events;
    }
    error_passive_ = true;
  }
  if (r.back_to_active) {
    error_passive_ = false;
  }
  if (r.restarted) {
    // The kernel restarted the controller (restart-ms): it is error active again. The
    // bus-off latch stays until the caller's restart(), so nothing resumes by itself.
    ++errors_.controller_restarts;
    restarted_since_bus_off_ = true;
    error_passive_ = false;
  }
  if (r.bus_off) {
    if (!bus_off_) {
      ++counters_.bus_off_events;
    }
    bus_off_ = true;
    restarted_since_bus_off_ = false;
  }
}

BusStatus SocketCanBus::receive(fw::CanFrame& frame) noexcept {
  if (fd_ < 0) {
    return BusStatus::kClosed;
  }
  if (bus_off_) {
    return BusStatus::kBusOff;
  }
  // Error frames are consumed here; bound the loop so an error storm cannot hold the
  // cycle (bus errors may flood): the rest are read on the next call.
  for (int i = 0; i < 64; ++i) {
    switch (read_one(frame)) {
      case Read::kFrame:
        ++counters_.rx_frames;
        return BusStatus::kOk;
      case Read::kErrorFrame:
        if (bus_off_) {
          return BusStatus::kBusOff;
        }
        continue;
      case Read::kNone:
        return BusStatus::kWouldBlock;
      case Read::kFailed:
        return BusStatus::kIoError;
    }
  }
  return BusStatus::kWouldBlock;
}

std::size_t SocketCanBus::receive_many(std::span<fw::CanFrame> frames, BusStatus& status) noexcept {
  status = BusStatus::kOk;
  if (fd_ < 0) {
    status = BusStatus::kClosed;
    return 0;
  }
  std::size_t got = 0;
  // Error frames are consumed here and not returned; bounded like receive() so an error
  // storm cannot hold the cycle: the rest are read on the next call.
  for (int round = 0; round < 4 && got < frames.size(); ++round) {
    if (bus_off_) {
      status = BusStatus::kBusOff;
      return got;
    }
    const std::size_t want = std::min(kBatch, frames.size() - got);
    std::array<canfd_frame, kBatch> cf;
    std::array<iovec, kBatch> iov{};
    std::array<mmsghdr, kBatch> msgs{};
    alignas(cmsghdr) unsigned char control[kBatch][kControlBytes];
    for (std::size_t k = 0; k < want; ++k) {
      iov[k] = iovec{&cf[k], sizeof(canfd_frame)};
      msgs[k].msg_hdr.msg_iov = &iov[k];
      msgs[k].msg_hdr.msg_iovlen = 1;
      msgs[k].msg_hdr.msg_control = control[k];
      msgs[k].msg_hdr.msg_controllen = kControlBytes;
    }
    const int r = ::recvmmsg(fd_, msgs.data(), static_cast<unsigned>(want), MSG_DONTWAIT, nullptr);
    if (r < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) {
        status = BusStatus::kWouldBlock;
      } else {
        last_errno_ = errno;
        status = BusStatus::kIoError;
      }
      return got;
    }
    for (int k = 0; k < r; ++k) {
      switch (take(cf[static_cast<std::size_t>(k)], msgs[static_cast<std::size_t>(k)].msg_hdr,
                   msgs[static_cast<std::size_t>(k)].msg_len, frames[got])) {
        case Read::kFrame:
          ++counters_.rx_frames;
          ++got;
          break;
        case Read::kErrorFrame:
          break;
        case Read::kNone:
        case Read::kFailed:
          status = BusStatus::kIoError;
          return got;
      }
    }
    if (static_cast<std::size_t>(r) < want) {  // the queue is empty
      if (bus_off_)
        status = BusStatus::kBusOff;
      else if (got < frames.size())
        status = BusStatus::kWouldBlock;
      return got;
    }
  }
  if (bus_off_) status = BusStatus::kBusOff;
  return got;
}

BusStatus SocketCanBus::state() const noexcept {
  if (fd_ < 0) {
    return BusStatus::kClosed;
  }
  if (bus_off_) {
    return BusStatus::kBusOff;
  }
  return error_passive_ ? BusStatus::kErrorPassive : BusStatus::kOk;
}

BusStatus SocketCanBus::restart() noexcept {
  if (fd_ < 0) {
    return BusStatus::kClosed;
  }
  // Drain everything queued so far: data frames are stale (discarded), error frames are
  // decoded (a CAN_ERR_RESTARTED may be among them). Bounded: a socket buffer holds at
  // most a few thousand frames; if traffic keeps arriving we stop after this many.
  fw::CanFrame discard;
  for (int i = 0; i < 100000; ++i) {
    const Read r = read_one(discard);
    if (r == Read::kNone) {
      break;
    }
    if (r == Read::kFailed) {
      return BusStatus::kIoError;
    }
  }
  if (bus_off_ && !virtual_ && !restarted_since_bus_off_) {
    // A real controller is still off: only the kernel (restart-ms) or an administrator
    // (`ip link set IF type can restart`, CAP_NET_ADMIN) can restart it.
    return BusStatus::kBusOff;
  }
  bus_off_ = false;
  error_passive_ = false;
  restarted_since_bus_off_ = false;
  ++counters_.restarts;
  return BusStatus::kOk;
}

bool SocketCanBus::wait_readable(std::chrono::nanoseconds timeout) const noexcept {
  if (fd_ < 0) {
    return false;
  }
  if (timeout.count() < 0) {
    timeout = std::chrono::nanoseconds(0);
  }
  pollfd p{fd_, POLLIN, 0};
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(timeout.count() / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(timeout.count() % 1'000'000'000);
  const int n = ::ppoll(&p, 1, &ts, nullptr);
  return n > 0 && (p.revents & POLLIN) != 0;
}

BusStatus SocketCanBus::receive_for(fw::CanFrame& frame,
                                    std::chrono::nanoseconds timeout) noexcept {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const BusStatus s = receive(frame);
    if (s != BusStatus::kWouldBlock) {
      return s;
    }
    const auto left = deadline - std::chrono::steady_clock::now();
    if (left <= std::chrono::nanoseconds(0)) {
      return BusStatus::kWouldBlock;
    }
    wait_readable(std::chrono::duration_cast<std::chrono::nanoseconds>(left));
  }
}

}  // namespace dualv::drivers
