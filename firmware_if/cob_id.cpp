#include "firmware_if/cob_id.hpp"

namespace dualv::fw {

const char* to_string(Function f) noexcept {
  switch (f) {
    case Function::kNmt:
      return "NMT";
    case Function::kSync:
      return "SYNC";
    case Function::kEmcy:
      return "EMCY";
    case Function::kTime:
      return "TIME";
    case Function::kTpdo1:
      return "TPDO1";
    case Function::kRpdo1:
      return "RPDO1";
    case Function::kTpdo2:
      return "TPDO2";
    case Function::kRpdo2:
      return "RPDO2";
    case Function::kTpdo3:
      return "TPDO3";
    case Function::kRpdo3:
      return "RPDO3";
    case Function::kTpdo4:
      return "TPDO4";
    case Function::kRpdo4:
      return "RPDO4";
    case Function::kSdoTx:
      return "SDO tx (response)";
    case Function::kSdoRx:
      return "SDO rx (request)";
    case Function::kHeartbeat:
      return "heartbeat";
    case Function::kBroadcastRpdo:
      return "broadcast RPDO";
  }
  return "?";
}

Result<CobIdInfo> classify(std::uint32_t id) noexcept {
  if (id > kMaxStandardId) return Error::kUnknownCobId;
  if (id == kNmtCobId) return CobIdInfo{Function::kNmt, 0};
  if (id == kSyncCobId) return CobIdInfo{Function::kSync, 0};
  if (id == kTimeCobId) return CobIdInfo{Function::kTime, 0};
  if (id == kBroadcastRpdoCobId) return CobIdInfo{Function::kBroadcastRpdo, 0};
  // Function code = bits 10..7, node = bits 6..0 (CiA 301 7.3.5 table 69).
  const auto code = static_cast<std::uint8_t>(id >> 7);
  const auto node = static_cast<std::uint8_t>(id & 0x7Fu);
  if (!is_valid_node_id(node)) return Error::kUnknownCobId;
  constexpr Function kByCode[16] = {
      Function::kNmt,   Function::kEmcy,  Function::kTime,      Function::kTpdo1,
      Function::kRpdo1, Function::kTpdo2, Function::kRpdo2,     Function::kTpdo3,
      Function::kRpdo3, Function::kTpdo4, Function::kRpdo4,     Function::kSdoTx,
      Function::kSdoRx, Function::kNmt,   Function::kHeartbeat, Function::kNmt};
  const Function f = kByCode[code & 0x0Fu];
  // Codes 0 (NMT), 2 (TIME), 13 (unused), 15 (LSS etc.) carry no node: unknown.
  if (!is_per_node(f)) return Error::kUnknownCobId;
  return CobIdInfo{f, node};
}

Result<CobIdInfo> classify(const CanFrame& frame) noexcept {
  if (frame.extended) return Error::kExtendedId;
  return classify(frame.id);
}

Result<std::uint8_t> expect_function(const CanFrame& frame, Function function) noexcept {
  const Result<CobIdInfo> info = classify(frame);
  if (!info) return info.error();
  if (info->function != function) return Error::kWrongFunction;
  if (frame.rtr) return Error::kRemoteFrame;
  return info->node;
}

}  // namespace dualv::fw
