#pragma once
// A classic CAN 2.0A/B data frame as the whole stack sees it: plain data, no I/O.
#include <array>
#include <cstdint>

namespace dualv::fw {

struct CanFrame {
  std::uint32_t id = 0;   // 11-bit (standard) or 29-bit (extended) identifier
  std::uint8_t dlc = 0;   // 0..8 data bytes
  bool extended = false;  // 29-bit identifier
  bool rtr = false;       // remote transmission request
  std::array<std::uint8_t, 8> data{};
  std::uint64_t timestamp_ns = 0;  // receive time (kernel or injected clock); 0 when unknown

  friend bool operator==(const CanFrame& a, const CanFrame& b) noexcept {
    return a.id == b.id && a.dlc == b.dlc && a.extended == b.extended && a.rtr == b.rtr &&
           a.data == b.data;  // timestamps are metadata, not content
  }
};

}  // namespace dualv::fw
