#include "firmware_if/heartbeat.hpp"

#include "firmware_if/cob_id.hpp"

namespace dualv::fw {

Result<CanFrame> encode_heartbeat(std::uint8_t node, NmtState state) noexcept {
  if (!is_valid_node_id(node)) return Error::kBadNodeId;
  CanFrame f;
  f.id = cob_id(Function::kHeartbeat, node);
  f.dlc = 1;
  f.data[0] = static_cast<std::uint8_t>(state);
  return f;
}

Result<Heartbeat> decode_heartbeat(const CanFrame& frame) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, Function::kHeartbeat);
  if (!node) return node.error();
  if (frame.dlc != 1) return Error::kWrongDlc;
  const std::uint8_t s = frame.data[0];
  if (s != 0x00 && s != 0x04 && s != 0x05 && s != 0x7F) return Error::kBadValue;
  return Heartbeat{*node, static_cast<NmtState>(s)};
}

}  // namespace dualv::fw
