#pragma once
// COB-IDs of the CiA 301 predefined connection set (CiA 301 7.3.5): an 11-bit identifier
// is a 4-bit function code and a 7-bit node id. classify() is the one decoder of it.
#include <cstdint>

#include "firmware_if/can_frame.hpp"
#include "firmware_if/result.hpp"

namespace dualv::fw {

inline constexpr std::uint8_t kMinNodeId = 1;
inline constexpr std::uint8_t kMaxNodeId = 127;
constexpr bool is_valid_node_id(std::uint8_t node) noexcept {
  return node >= kMinNodeId && node <= kMaxNodeId;
}

enum class Function : std::uint8_t {
  kNmt,        // 000h, broadcast, master -> all
  kSync,       // 080h
  kEmcy,       // 080h + node
  kTime,       // 100h
  kTpdo1,      // 180h + node (drive -> host)
  kRpdo1,      // 200h + node (host -> drive)
  kTpdo2,      // 280h + node
  kRpdo2,      // 300h + node
  kTpdo3,      // 380h + node
  kRpdo3,      // 400h + node
  kTpdo4,      // 480h + node
  kRpdo4,      // 500h + node
  kSdoTx,      // 580h + node: server (drive) -> client (host), "SDO response"
  kSdoRx,      // 600h + node: client (host) -> server (drive), "SDO request"
  kHeartbeat,  // 700h + node: NMT error control (boot-up, heartbeat)
  // 200h (RPDO1 function code with node 0, outside the predefined set but not restricted by
  // CiA 301 7.3.5 table 70): the broadcast RPDO of pdo.hpp carrying all target torques.
  kBroadcastRpdo,
};

const char* to_string(Function f) noexcept;

inline constexpr std::uint16_t kNmtCobId = 0x000;
inline constexpr std::uint16_t kSyncCobId = 0x080;
inline constexpr std::uint16_t kTimeCobId = 0x100;
inline constexpr std::uint16_t kEmcyBase = 0x080;
inline constexpr std::uint16_t kTpdo1Base = 0x180;
inline constexpr std::uint16_t kRpdo1Base = 0x200;
inline constexpr std::uint16_t kTpdo2Base = 0x280;
inline constexpr std::uint16_t kRpdo2Base = 0x300;
inline constexpr std::uint16_t kTpdo3Base = 0x380;
inline constexpr std::uint16_t kRpdo3Base = 0x400;
inline constexpr std::uint16_t kTpdo4Base = 0x480;
inline constexpr std::uint16_t kRpdo4Base = 0x500;
inline constexpr std::uint16_t kSdoTxBase = 0x580;
inline constexpr std::uint16_t kSdoRxBase = 0x600;
inline constexpr std::uint16_t kHeartbeatBase = 0x700;
inline constexpr std::uint16_t kBroadcastRpdoCobId = 0x200;
inline constexpr std::uint16_t kMaxStandardId = 0x7FF;

// Base identifier of a function (the whole id for NMT, SYNC, TIME, broadcast RPDO).
constexpr std::uint16_t function_base(Function f) noexcept {
  switch (f) {
    case Function::kNmt:
      return kNmtCobId;
    case Function::kSync:
      return kSyncCobId;
    case Function::kEmcy:
      return kEmcyBase;
    case Function::kTime:
      return kTimeCobId;
    case Function::kTpdo1:
      return kTpdo1Base;
    case Function::kRpdo1:
      return kRpdo1Base;
    case Function::kTpdo2:
      return kTpdo2Base;
    case Function::kRpdo2:
      return kRpdo2Base;
    case Function::kTpdo3:
      return kTpdo3Base;
    case Function::kRpdo3:
      return kRpdo3Base;
    case Function::kTpdo4:
      return kTpdo4Base;
    case Function::kRpdo4:
      return kRpdo4Base;
    case Function::kSdoTx:
      return kSdoTxBase;
    case Function::kSdoRx:
      return kSdoRxBase;
    case Function::kHeartbeat:
      return kHeartbeatBase;
    case Function::kBroadcastRpdo:
      return kBroadcastRpdoCobId;
  }
  return 0;
}
constexpr bool is_per_node(Function f) noexcept {
  return !(f == Function::kNmt || f == Function::kSync || f == Function::kTime ||
           f == Function::kBroadcastRpdo);
}

// TPDO n / RPDO n (n = 1..4) as a function; kTpdo1 for out-of-range n is never returned:
// callers pass constants.
constexpr Function tpdo_function(std::uint8_t n) noexcept {
  constexpr Function f[] = {Function::kTpdo1, Function::kTpdo2, Function::kTpdo3, Function::kTpdo4};
  return f[(n >= 1 && n <= 4) ? n - 1 : 0];
}
constexpr Function rpdo_function(std::uint8_t n) noexcept {
  constexpr Function f[] = {Function::kRpdo1, Function::kRpdo2, Function::kRpdo3, Function::kRpdo4};
  return f[(n >= 1 && n <= 4) ? n - 1 : 0];
}

// The COB-ID of a per-node function for `node`; for NMT/SYNC/TIME/broadcast the node is
// ignored. Precondition for per-node functions: is_valid_node_id(node) (checked in
// make_cob_id below).
constexpr std::uint16_t cob_id(Function f, std::uint8_t node) noexcept {
  return is_per_node(f) ? static_cast<std::uint16_t>(function_base(f) + (node & 0x7Fu))
                        : function_base(f);
}
constexpr Result<std::uint16_t> make_cob_id(Function f, std::uint8_t node) noexcept {
  if (is_per_node(f) && !is_valid_node_id(node)) return Error::kBadNodeId;
  return cob_id(f, node);
}

struct CobIdInfo {
  Function function = Function::kNmt;
  std::uint8_t node = 0;  // 0 for NMT, SYNC, TIME and the broadcast RPDO
  friend constexpr bool operator==(const CobIdInfo&, const CobIdInfo&) = default;
};

// Classifies an 11-bit identifier; kUnknownCobId for anything outside the set above
// (e.g. 001h..07Fh, 181h..1FFh with node 0, LSS 7E4h/7E5h, ids above 7FFh).
Result<CobIdInfo> classify(std::uint32_t id) noexcept;
// Same for a received frame; kExtendedId for 29-bit frames (the predefined set is 11-bit).
Result<CobIdInfo> classify(const CanFrame& frame) noexcept;

// Common front half of every decoder: a standard data frame (not RTR) whose id classifies
// as `function`. Returns the node (0 for functions without one). kWrongFunction when the id
// is valid but belongs to another function.
Result<std::uint8_t> expect_function(const CanFrame& frame, Function function) noexcept;

}  // namespace dualv::fw
