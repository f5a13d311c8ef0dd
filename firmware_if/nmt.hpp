#pragma once
// NMT module control (CiA 301 7.2.8.3.1): COB-ID 000h, DLC 2, byte 0 = command
// specifier, byte 1 = node id (0 = all nodes). And the NMT states a node reports.
#include <cstdint>

#include "firmware_if/can_frame.hpp"
#include "firmware_if/result.hpp"

namespace dualv::fw {

enum class NmtCommand : std::uint8_t {
  kStart = 0x01,                // -> Operational
  kStop = 0x02,                 // -> Stopped
  kEnterPreOperational = 0x80,  // -> Pre-operational
  kResetNode = 0x81,            // application + communication reset
  kResetCommunication = 0x82,   // communication reset only
};
const char* to_string(NmtCommand c) noexcept;

// NMT state as carried by heartbeat / boot-up (CiA 301 7.2.8.3.2.1, table 61).
enum class NmtState : std::uint8_t {
  kBootUp = 0x00,  // the boot-up message (sent once, entering Pre-operational)
  kStopped = 0x04,
  kOperational = 0x05,
  kPreOperational = 0x7F,
};
const char* to_string(NmtState s) noexcept;

inline constexpr std::uint8_t kNmtAllNodes = 0;

struct NmtMessage {
  NmtCommand command = NmtCommand::kStart;
  std::uint8_t node = 0;  // 0 = all nodes
  friend constexpr bool operator==(const NmtMessage&, const NmtMessage&) = default;
};

// node: 0 (all) or 1..127; kBadNodeId otherwise.
Result<CanFrame> encode_nmt(NmtCommand command, std::uint8_t node) noexcept;
// kWrongFunction (not 000h), kWrongDlc (not 2), kBadValue (unknown command),
// kBadNodeId (node > 127).
Result<NmtMessage> decode_nmt(const CanFrame& frame) noexcept;
// True when a node with id `self` must act on the message.
constexpr bool addressed_to(const NmtMessage& m, std::uint8_t self) noexcept {
  return m.node == kNmtAllNodes || m.node == self;
}

}  // namespace dualv::fw
