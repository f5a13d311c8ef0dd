#include "firmware_if/nmt.hpp"

#include "firmware_if/cob_id.hpp"

namespace dualv::fw {

const char* to_string(NmtCommand c) noexcept {
  switch (c) {
    case NmtCommand::kStart:
      return "start remote node";
    case NmtCommand::kStop:
      return "stop remote node";
    case NmtCommand::kEnterPreOperational:
      return "enter pre-operational";
    case NmtCommand::kResetNode:
      return "reset node";
    case NmtCommand::kResetCommunication:
      return "reset communication";
  }
  return "?";
}

const char* to_string(NmtState s) noexcept {
  switch (s) {
    case NmtState::kBootUp:
      return "boot-up";
    case NmtState::kStopped:
      return "stopped";
    case NmtState::kOperational:
      return "operational";
    case NmtState::kPreOperational:
      return "pre-operational";
  }
  return "?";
}

namespace {
constexpr bool is_command(std::uint8_t cs) noexcept {
  return cs == 0x01 || cs == 0x02 || cs == 0x80 || cs == 0x81 || cs == 0x82;
}
}  // namespace

Result<CanFrame> encode_nmt(NmtCommand command, std::uint8_t node) noexcept {
  if (node != kNmtAllNodes && !is_valid_node_id(node)) return Error::kBadNodeId;
  if (!is_command(static_cast<std::uint8_t>(command))) return Error::kBadValue;
  CanFrame f;
  f.id = kNmtCobId;
  f.dlc = 2;
  f.data[0] = static_cast<std::uint8_t>(command);
  f.data[1] = node;
  return f;
}

Result<NmtMessage> decode_nmt(const CanFrame& frame) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, Function::kNmt);
  if (!node) return node.error();
  if (frame.dlc != 2) return Error::kWrongDlc;
  if (!is_command(frame.data[0])) return Error::kBadValue;
  if (frame.data[1] > kMaxNodeId) return Error::kBadNodeId;
  return NmtMessage{static_cast<NmtCommand>(frame.data[0]), frame.data[1]};
}

}  // namespace dualv::fw
