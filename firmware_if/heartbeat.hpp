#pragma once
// NMT error control, heartbeat protocol (CiA 301 7.2.8.3.2.2): COB-ID 700h + node, DLC 1,
// byte 0 = NMT state (bit 7 reserved, 0 for heartbeat; node guarding's toggle is not
// used by this stack). The boot-up message is the same frame with state 00h.
#include <cstdint>

#include "firmware_if/can_frame.hpp"
#include "firmware_if/nmt.hpp"
#include "firmware_if/result.hpp"

namespace dualv::fw {

struct Heartbeat {
  std::uint8_t node = 0;
  NmtState state = NmtState::kBootUp;
  friend constexpr bool operator==(const Heartbeat&, const Heartbeat&) = default;
};

// kBadNodeId when node is outside 1..127.
Result<CanFrame> encode_heartbeat(std::uint8_t node, NmtState state) noexcept;
// kWrongFunction, kWrongDlc (not 1), kBadValue (state byte not in table 61 or bit 7 set).
Result<Heartbeat> decode_heartbeat(const CanFrame& frame) noexcept;

// 1016h sub n value (CiA 301 7.5.2.19): bits 23..16 = node id of the producer watched,
// bits 15..0 = heartbeat time in ms (0 = not used); bits 31..24 reserved (0).
constexpr std::uint32_t consumer_heartbeat_value(std::uint8_t node,
                                                 std::uint16_t time_ms) noexcept {
  return (static_cast<std::uint32_t>(node) << 16) | time_ms;
}
constexpr std::uint8_t consumer_heartbeat_node(std::uint32_t value) noexcept {
  return static_cast<std::uint8_t>((value >> 16) & 0xFFu);
}
constexpr std::uint16_t consumer_heartbeat_time_ms(std::uint32_t value) noexcept {
  return static_cast<std::uint16_t>(value & 0xFFFFu);
}

}  // namespace dualv::fw
