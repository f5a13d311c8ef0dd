#pragma once
// CanBus on a Linux SocketCAN interface (real controller or vcan): one raw socket
// (PF_CAN, SOCK_RAW, CAN_RAW), non-blocking.
//
// - Receive filters: a list of id/mask pairs applied in the kernel (CAN_RAW_FILTER).
// - Error frames are enabled (CAN_RAW_ERR_FILTER) and decoded (socketcan_error.hpp) into
//   state() and counters(); receive() never hands an error frame to the caller.
// - Kernel receive timestamps (SO_TIMESTAMPNS): CanFrame::timestamp_ns is CLOCK_REALTIME
//   at the moment the kernel queued the frame.
// - Frames lost because our socket receive buffer was full are counted (SO_RXQ_OVFL) in
//   counters().rx_overruns.
// - send(): ENOBUFS/EAGAIN (queue full) -> kWouldBlock, counted in tx_dropped.
// - CAN FD (SocketCanConfig::fd_frames): CAN_RAW_FD_FRAMES on, the interface must carry FD
//   frames (MTU 72: `ip link set vcan0 mtu 72`, or a controller set up with `fd on`), and
//   struct canfd_frame is read and written; classic frames still pass on the same socket.
//   Without it an FD frame is refused by send() (kIoError, EINVAL).
// - Bus-off (from an error frame) is latched: send/receive return kBusOff until restart().
//
// restart() and privileges: leaving bus-off on a real controller means restarting it,
// which the kernel does by itself when the interface has a restart delay configured
// (`ip link set can0 type can restart-ms 100`, or systemd-networkd `[CAN] RestartSec=`);
// a manual `ip link set can0 type can restart` needs CAP_NET_ADMIN, which this process
// does not take. So on a real controller restart() succeeds only once the kernel has
// reported the controller restarted (CAN_ERR_RESTARTED); until then it returns kBusOff.
// On vcan/vxcan there is no controller: restart() just clears the latch. In both cases it
// drains the socket receive queue so frames received before the fault are never
// processed. Frames queued for transmission in the kernel are dropped by the kernel itself
// when a controller goes bus-off (carrier off resets the queue); we keep no queue of our own.
//
// Real-time safe: send/receive/state/restart/counters are noexcept, allocate nothing and
// make one or a few syscalls. The constructor and wait_readable are for set-up and non-RT
// threads.
#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "drivers/can/can_bus.hpp"
#include "drivers/can/socketcan_error.hpp"

struct canfd_frame;  // <linux/can.h>
struct msghdr;       // <sys/socket.h>

namespace dualv::drivers {

// Thrown by constructors when the bus cannot be set up; what() says what to fix.
class CanSetupError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A frame passes when (frame.id & mask) == (id & mask), for frames of the same format
// (standard or extended; set extended for 29-bit ids). RTR frames pass like data frames.
struct CanFilter {
  std::uint32_t id = 0;
  std::uint32_t mask = 0x7FF;
  bool extended = false;
};

struct SocketCanConfig {
  std::string interface = "vcan0";
  std::vector<CanFilter> filters;  // empty: receive every data frame
  int receive_buffer_bytes = 0;    // SO_RCVBUF; 0 keeps the kernel default
  int send_buffer_bytes = 0;       // SO_SNDBUF; 0 keeps the kernel default (small values
                                   // make ENOBUFS/EAGAIN reachable in tests)
  bool fd_frames = false;          // CAN FD frames too (CAN_RAW_FD_FRAMES; see above)
};

// Details of error frames beyond BusCounters, for health reports.
struct CanErrorStats {
  std::uint64_t warnings = 0;  // error counter reached warning level
  std::uint64_t no_ack = 0;    // nobody acknowledged (no other node, open bus)
  std::uint64_t protocol = 0;  // bit/form/stuff errors
  std::uint64_t lost_arbitration = 0;
  std::uint64_t controller_overflows = 0;  // controller RX or TX buffer overflow
  std::uint64_t transceiver = 0;
  std::uint64_t tx_timeouts = 0;
  std::uint64_t bus_errors = 0;
  std::uint64_t controller_restarts = 0;  // CAN_ERR_RESTARTED seen
  std::uint8_t tx_error_counter = 0;      // last reported (CAN_ERR_CNT)
  std::uint8_t rx_error_counter = 0;
  CanErrorReport last{};  // the last error frame decoded
};

class SocketCanBus final : public CanBus {
 public:
  // Throws CanSetupError naming the interface and what to do (create it, bring it up,
  // load the kernel modules).
  explicit SocketCanBus(const SocketCanConfig& config);
  ~SocketCanBus() override;
  SocketCanBus(const SocketCanBus&) = delete;
  SocketCanBus& operator=(const SocketCanBus&) = delete;

  // Control data per received message: the timestamp and the drop counter.
  static constexpr std::size_t kControlBytes = 64;

  BusStatus send(const fw::CanFrame& frame) noexcept override;
  BusStatus receive(fw::CanFrame& frame) noexcept override;
  std::size_t send_many(std::span<const fw::CanFrame> frames, BusStatus& status) noexcept override;
  std::size_t receive_many(std::span<fw::CanFrame> frames, BusStatus& status) noexcept override;
  BusStatus state() const noexcept override;
  BusStatus restart() noexcept override;
  const BusCounters& counters() const noexcept override { return counters_; }

  const CanErrorStats& error_stats() const noexcept { return errors_; }
  const std::string& interface_name() const noexcept { return interface_; }
  // True when the socket carries CAN FD frames (SocketCanConfig::fd_frames).
  bool fd_frames() const noexcept { return fd_frames_; }
  // True on vcan/vxcan (no controller, no bus-off of its own).
  bool is_virtual() const noexcept { return virtual_; }
  // errno of the last failed syscall in send/receive (0 if none), for diagnostics.
  int last_errno() const noexcept { return last_errno_; }
  int fd() const noexcept { return fd_; }

  // Non-RT helper: blocks (poll) until a frame or error frame can be read or the timeout
  // passes. Returns true when readable. Never use in the cycle.
  bool wait_readable(std::chrono::nanoseconds timeout) const noexcept;
  // Non-RT helper: wait_readable then receive, skipping error frames, until a frame
  // arrives or the timeout passes (kWouldBlock), or the bus is off (kBusOff).
  BusStatus receive_for(fw::CanFrame& frame, std::chrono::nanoseconds timeout) noexcept;

 private:
  enum class Read : std::uint8_t { kFrame, kErrorFrame, kNone, kFailed };
  Read read_one(fw::CanFrame& frame) noexcept;
  // One received message (frame or error frame) with its control data, into `frame`.
  Read take(const ::canfd_frame& cf, ::msghdr& msg, std::size_t bytes,
            fw::CanFrame& frame) noexcept;

  void on_error_frame(std::uint32_t can_id, const std::array<std::uint8_t, 8>& data) noexcept;

  std::string interface_;
  int fd_ = -1;
  bool virtual_ = false;
  bool fd_frames_ = false;
  bool bus_off_ = false;
  bool error_passive_ = false;
  bool restarted_since_bus_off_ = false;
  std::uint32_t last_drop_count_ = 0;  // SO_RXQ_OVFL is cumulative
  int last_errno_ = 0;
  BusCounters counters_{};
  CanErrorStats errors_{};
};

}  // namespace dualv::drivers
