#pragma once
// How the fuzz targets read CAN frames from fuzz input, and compare frames on the wire.
// A frame is 12 bytes (short input is padded with zeros, so every input is a frame):
//   0..1  identifier, u16 LE (11 bits are used; 0x800 and above read as 29-bit extended)
//   2     flags: bit 0 RTR
//   3     DLC, taken modulo 9 (a classic frame holds 0..8 bytes: firmware_if/can_frame.hpp)
//   4..11 data
#include <fuzzer/FuzzedDataProvider.h>
#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "firmware_if/can_frame.hpp"

namespace dualv::fuzz {

inline constexpr std::size_t kFrameBytes = 12;

inline fw::CanFrame frame_from(const std::uint8_t* bytes, std::size_t size) noexcept {
  std::uint8_t b[kFrameBytes] = {};
  std::copy_n(bytes, std::min(size, kFrameBytes), b);
  fw::CanFrame f;
  const std::uint32_t raw =
      static_cast<std::uint32_t>(b[0]) | (static_cast<std::uint32_t>(b[1]) << 8);
  f.extended = raw > 0x7FF;
  f.id = f.extended ? (raw * 0x9E37u) & 0x1FFFFFFFu : raw;  // any 29-bit id, deterministic
  f.rtr = (b[2] & 1u) != 0;
  f.dlc = static_cast<std::uint8_t>(b[3] % 9u);
  std::copy_n(b + 4, 8, f.data.begin());
  return f;
}

inline fw::CanFrame consume_frame(FuzzedDataProvider& in) {
  std::uint8_t b[kFrameBytes] = {};
  const std::size_t n = in.ConsumeData(b, kFrameBytes);
  return frame_from(b, n);
}

// Same frame on the wire: identifier, format, RTR, DLC and the DLC bytes of data (bytes past
// the DLC are not transmitted, so they do not count).
inline bool same_wire(const fw::CanFrame& a, const fw::CanFrame& b) noexcept {
  return a.id == b.id && a.extended == b.extended && a.rtr == b.rtr && a.dlc == b.dlc &&
         std::equal(a.data.begin(), a.data.begin() + std::min<std::uint8_t>(a.dlc, 8),
                    b.data.begin());
}

}  // namespace dualv::fuzz
