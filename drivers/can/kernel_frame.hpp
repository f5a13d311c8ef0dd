#pragma once
// The one conversion each way between fw::CanFrame (firmware_if/can_frame.hpp) and the Linux
// kernel's SocketCAN frame (linux/can.h, Documentation/networking/can.rst "CAN FD (Flexible
// Data Rate) Driver Support"), used by drivers/can/socketcan_bus.cpp. Real-time safe: no
// allocation, no syscalls.
#include <linux/can.h>
#include <sys/types.h>

#include <algorithm>
#include <cstddef>
#include <cstring>

#include "firmware_if/can_frame.hpp"

namespace dualv::drivers {

// The one conversion each way between fw::CanFrame and the kernel's frame (linux/can.h): a
// classic frame is the first CAN_MTU bytes of a canfd_frame (same header layout), an FD frame
// all CANFD_MTU. Returns the bytes to write, 0 for a frame the socket cannot send (invalid,
// or FD on a socket without CAN_RAW_FD_FRAMES).
inline std::size_t to_kernel(const fw::CanFrame& f, bool fd_socket, canfd_frame& k) noexcept {
  if (!fw::is_valid(f) || (f.fd && !fd_socket)) return 0;
  k = canfd_frame{};
  k.can_id = f.extended ? ((f.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (f.id & CAN_SFF_MASK);
  if (f.rtr) k.can_id |= CAN_RTR_FLAG;
  k.len = f.dlc;
  if (f.fd) k.flags = static_cast<__u8>(CANFD_FDF | (f.brs ? CANFD_BRS : 0));
  std::memcpy(k.data, f.data.data(), f.dlc);
  return f.fd ? CANFD_MTU : CAN_MTU;
}
// `n` bytes read into `k`: false when n is neither CAN_MTU nor CANFD_MTU. Error frames are
// the caller's (CAN_ERR_FLAG in can_id).
inline bool from_kernel(const canfd_frame& k, ssize_t n, fw::CanFrame& f) noexcept {
  if (n != static_cast<ssize_t>(CAN_MTU) && n != static_cast<ssize_t>(CANFD_MTU)) return false;
  f.fd = n == static_cast<ssize_t>(CANFD_MTU);
  f.brs = f.fd && (k.flags & CANFD_BRS) != 0;
  f.extended = (k.can_id & CAN_EFF_FLAG) != 0;
  f.rtr = !f.fd && (k.can_id & CAN_RTR_FLAG) != 0;
  f.id = k.can_id & (f.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
  f.dlc = std::min<std::uint8_t>(k.len, f.fd ? CANFD_MAX_DLEN : CAN_MAX_DLEN);
  f.data = {};
  std::memcpy(f.data.data(), k.data, f.dlc);
  return true;
}

}  // namespace dualv::drivers
