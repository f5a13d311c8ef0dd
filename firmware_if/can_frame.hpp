#pragma once
// A CAN data frame as the whole stack sees it, classic CAN 2.0A/B or CAN FD (ISO 11898-1:2015):
// plain data, no I/O.
//
// `dlc` is the number of data bytes (SocketCAN's `len`), never the 4-bit DLC code: 0..8 for a
// classic frame; for an FD frame one of the sizes the 16 codes stand for, 0..8, 12, 16, 20, 24,
// 32, 48, 64 (fd_dlc_code() gives the code on the wire). A classic frame's bytes beyond 8, and
// any frame's bytes beyond `dlc`, are zero.
#include <array>
#include <cstdint>

namespace dualv::fw {

inline constexpr std::uint8_t kClassicMaxBytes = 8;
inline constexpr std::uint8_t kFdMaxBytes = 64;
// Payload sizes of the 16 DLC codes of an FD frame (ISO 11898-1:2015 table 5: 9..15 =
// 12..64 bytes); a classic frame's codes 9..15 all mean 8.
inline constexpr std::array<std::uint8_t, 16> kFdDlcBytes{0, 1,  2,  3,  4,  5,  6,  7,
                                                          8, 12, 16, 20, 24, 32, 48, 64};

struct CanFrame {
  std::uint32_t id = 0;   // 11-bit (standard) or 29-bit (extended) identifier
  std::uint8_t dlc = 0;   // data bytes: 0..8 classic, a kFdDlcBytes size for FD (see above)
  bool extended = false;  // 29-bit identifier
  bool rtr = false;       // remote transmission request (classic only: FD has no remote frames)
  bool fd = false;        // CAN FD frame (FDF bit): up to 64 data bytes
  bool brs = false;       // FD only: data phase at the data bit rate (bit rate switch)
  std::array<std::uint8_t, kFdMaxBytes> data{};
  std::uint64_t timestamp_ns = 0;  // receive time (kernel or injected clock); 0 when unknown

  friend bool operator==(const CanFrame& a, const CanFrame& b) noexcept {
    return a.id == b.id && a.dlc == b.dlc && a.extended == b.extended && a.rtr == b.rtr &&
           a.fd == b.fd && a.brs == b.brs &&
           a.data == b.data;  // timestamps are metadata, not content
  }
};

// True when `bytes` is the size of one of the 16 FD DLC codes.
constexpr bool is_fd_length(std::uint8_t bytes) noexcept {
  for (std::uint8_t size : kFdDlcBytes)
    if (size == bytes) return true;
  return false;
}
// The frame size a payload of `bytes` needs (the smallest DLC size >= bytes; 64 at most).
constexpr std::uint8_t fd_frame_bytes(std::uint8_t bytes) noexcept {
  for (std::uint8_t size : kFdDlcBytes)
    if (size >= bytes) return size;
  return kFdMaxBytes;
}
// The 4-bit DLC code on the wire for a frame of `bytes` (an FD size; others round up).
constexpr std::uint8_t fd_dlc_code(std::uint8_t bytes) noexcept {
  for (std::uint8_t code = 0; code < kFdDlcBytes.size(); ++code)
    if (kFdDlcBytes[code] >= bytes) return code;
  return 15;
}
// A frame a controller can send: classic with 0..8 bytes and no BRS, or FD with an FD size
// and no RTR; identifier within its format.
constexpr bool is_valid(const CanFrame& f) noexcept {
  if (f.id > (f.extended ? 0x1FFFFFFFu : 0x7FFu)) return false;
  if (!f.fd) return f.dlc <= kClassicMaxBytes && !f.brs;
  return is_fd_length(f.dlc) && !f.rtr;
}

// A frame with `bytes` of payload, FD (with BRS) when `fd` or when it does not fit a classic
// frame; the FD size rounded up to the next DLC size (the padding bytes are zero).
constexpr CanFrame data_frame(std::uint32_t id, std::uint8_t bytes, bool fd) noexcept {
  CanFrame f;
  f.id = id;
  f.fd = fd || bytes > kClassicMaxBytes;
  f.brs = f.fd;
  f.dlc = f.fd ? fd_frame_bytes(bytes) : bytes;
  return f;
}

}  // namespace dualv::fw
