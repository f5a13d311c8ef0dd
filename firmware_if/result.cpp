#include "firmware_if/result.hpp"

namespace dualv::fw {

const char* to_string(Error e) noexcept {
  switch (e) {
    case Error::kNone:
      return "ok";
    case Error::kWrongDlc:
      return "wrong data length";
    case Error::kUnknownCobId:
      return "unknown COB-ID";
    case Error::kWrongFunction:
      return "COB-ID of another function";
    case Error::kWrongNode:
      return "COB-ID of another node";
    case Error::kBadNodeId:
      return "node id outside 1..127";
    case Error::kExtendedId:
      return "29-bit identifier";
    case Error::kRemoteFrame:
      return "remote frame";
    case Error::kBadCommandSpecifier:
      return "bad SDO command specifier";
    case Error::kToggleMismatch:
      return "SDO toggle bit not alternated";
    case Error::kBadValue:
      return "undefined field value";
    case Error::kTooLong:
      return "payload too long";
    case Error::kSizeMismatch:
      return "transfer size does not match";
  }
  return "?";
}

}  // namespace dualv::fw
