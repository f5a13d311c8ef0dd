#pragma once
// PDO mapping (CiA 301 7.4.7.1 / 7.5.2.36) and the PDO layouts of the CAN contract
// (docs/architecture.md): per-drive RPDO1 = controlword + target torque, TPDO1 = statusword +
// position actual; or one broadcast RPDO carrying every drive's target torque ("Beating the naive
// bus limit", issue 15), the cyclic TPDO1 with the position alone, and the controlword (RPDO1) and
// the statusword (TPDO3) as event-driven PDOs bounded by their inhibit times; or CAN FD: one FD
// RPDO with every drive's controlword + torque and TPDO1 (statusword + position) as FD frames.
#include <array>
#include <cstdint>

#include "firmware_if/can_frame.hpp"
#include "firmware_if/cob_id.hpp"
#include "firmware_if/object_dictionary.hpp"
#include "firmware_if/result.hpp"

namespace dualv::fw {

// One mapping entry, on the wire as u32 0xIIIISSLL: index, subindex, length in bits.
struct PdoMapEntry {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  std::uint8_t bits = 0;
  friend constexpr bool operator==(const PdoMapEntry&, const PdoMapEntry&) = default;
};
constexpr std::uint32_t encode_mapping(const PdoMapEntry& e) noexcept {
  return (static_cast<std::uint32_t>(e.index) << 16) |
         (static_cast<std::uint32_t>(e.subindex) << 8) | e.bits;
}
constexpr PdoMapEntry decode_mapping(std::uint32_t v) noexcept {
  return PdoMapEntry{static_cast<std::uint16_t>(v >> 16),
                     static_cast<std::uint8_t>((v >> 8) & 0xFFu),
                     static_cast<std::uint8_t>(v & 0xFFu)};
}
constexpr PdoMapEntry map_entry(const OdEntry& e) noexcept {
  return PdoMapEntry{e.index, e.subindex, e.bits()};
}
// Dummy entry: the data type's index (0002h..0007h), subindex 0 (CiA 301 7.4.7.1). The
// receiving drive skips those bytes; only RPDOs may carry dummies.
constexpr PdoMapEntry dummy_entry(DataType t) noexcept {
  return PdoMapEntry{static_cast<std::uint16_t>(t), 0, static_cast<std::uint8_t>(8 * size_of(t))};
}
constexpr bool is_dummy(const PdoMapEntry& e) noexcept {
  return e.index >= 0x0001 && e.index <= 0x0007 && e.subindex == 0;
}

struct PdoLayout {
  std::array<PdoMapEntry, od::kPdoMaxMappedObjects> entries{};
  std::uint8_t count = 0;
  constexpr std::uint32_t total_bits() const noexcept {
    std::uint32_t b = 0;
    for (std::uint8_t i = 0; i < count && i < entries.size(); ++i) b += entries[i].bits;
    return b;
  }
  constexpr std::uint8_t bytes() const noexcept {
    return static_cast<std::uint8_t>((total_bits() + 7) / 8);
  }
  // Byte offset of the first entry mapping (index, subindex), or -1 when not mapped.
  constexpr int offset_of(const OdEntry& e) const noexcept {
    std::uint32_t bit = 0;
    for (std::uint8_t i = 0; i < count && i < entries.size(); ++i) {
      if (entries[i].index == e.index && entries[i].subindex == e.subindex)
        return static_cast<int>(bit / 8);
      bit += entries[i].bits;
    }
    return -1;
  }
  friend constexpr bool operator==(const PdoLayout&, const PdoLayout&) = default;
};

// 1400h/1800h sub1 value (CiA 301 7.5.2.35): bit 31 = PDO not valid, bit 30 = no RTR
// allowed (TPDO), bits 10..0 the COB-ID. Write "not valid" before changing a mapping.
inline constexpr std::uint32_t kPdoCobIdInvalid = 1u << 31;
inline constexpr std::uint32_t kPdoCobIdNoRtr = 1u << 30;
constexpr std::uint32_t pdo_cob_id_value(std::uint16_t cob_id, bool valid,
                                         bool rtr_allowed = false) noexcept {
  return (valid ? 0u : kPdoCobIdInvalid) | (rtr_allowed ? 0u : kPdoCobIdNoRtr) |
         (cob_id & kMaxStandardId);
}

// Transmission types (1400h/1800h sub2, CiA 301 7.5.2.35 table 72).
inline constexpr std::uint8_t kTransmissionSyncEvery = 1;  // cyclic synchronous, every SYNC
inline constexpr std::uint8_t kTransmissionEventManufacturer = 0xFE;
inline constexpr std::uint8_t kTransmissionEventProfile = 0xFF;  // asynchronous, on change

// ---- the contract's layouts ----------------------------------------------------------
// The layout of the cyclic traffic, `can.bus_layout` (docs/architecture.md "CAN contract"):
enum class BusLayout : std::uint8_t {
  kPerDrive,   // RPDO1 0x200+id: controlword u16 + target torque i16, TPDO1 0x180+id:
               // statusword + position, every SYNC
  kBroadcast,  // one frame on kBroadcastRpdoCobId with all target torques (i16 each),
               // every SYNC; per drive RPDO1 0x200+id = controlword (on change), TPDO1
               // 0x180+id = position (every SYNC), TPDO3 0x380+id = statusword (on change)
  kFd,         // CAN FD: one FD frame on kBroadcastRpdoCobId with every drive's controlword +
               // target torque (4 B each), TPDO1 0x180+id = statusword + position as an FD
               // frame, every SYNC
};
inline constexpr std::array<BusLayout, 3> kBusLayouts{BusLayout::kPerDrive, BusLayout::kBroadcast,
                                                      BusLayout::kFd};
// The value of `can.bus_layout`: per_drive, broadcast, fd.
constexpr const char* to_string(BusLayout l) noexcept {
  switch (l) {
    case BusLayout::kPerDrive:
      return "per_drive";
    case BusLayout::kBroadcast:
      return "broadcast";
    case BusLayout::kFd:
      return "fd";
  }
  return "?";
}

inline constexpr PdoLayout kRpdo1Layout{{map_entry(od::kControlword), map_entry(od::kTargetTorque)},
                                        2};
inline constexpr PdoLayout kTpdo1Layout{
    {map_entry(od::kStatusword), map_entry(od::kPositionActual)}, 2};
// Broadcast mode: RPDO1 carries the controlword alone, RPDO2 is the broadcast frame.
inline constexpr PdoLayout kControlwordRpdoLayout{{map_entry(od::kControlword)}, 1};
inline constexpr std::uint8_t kBroadcastRpdoNumber = 2;
// Broadcast mode: TPDO1 carries the position alone (every SYNC), TPDO3 the statusword
// (transmission type 255, on change, at most once per inhibit time 1802h sub3 and at least
// once per event timer 1802h sub5).
inline constexpr PdoLayout kPositionTpdoLayout{{map_entry(od::kPositionActual)}, 1};
inline constexpr PdoLayout kStatuswordTpdoLayout{{map_entry(od::kStatusword)}, 1};
inline constexpr std::uint8_t kStatuswordTpdoNumber = 3;
inline constexpr std::uint8_t kBroadcastMaxDrives = 4;  // 8 bytes / 2 per i16 torque

// The broadcast RPDO mapping of the drive in `slot` (0..drives-1): its own target torque
// at bytes 2*slot..2*slot+1, INTEGER16 dummies for the others. Slot out of range gives an
// all-dummy layout (count 0 when drives is out of 1..4).
constexpr PdoLayout broadcast_rpdo_layout(std::uint8_t slot, std::uint8_t drives) noexcept {
  PdoLayout l;
  if (drives < 1 || drives > kBroadcastMaxDrives) return l;
  for (std::uint8_t i = 0; i < drives; ++i)
    l.entries[i] = (i == slot) ? map_entry(od::kTargetTorque) : dummy_entry(DataType::kInteger16);
  l.count = drives;
  return l;
}

// CAN FD mode: RPDO2 on kBroadcastRpdoCobId, an FD frame; the drive in `slot` maps its own
// controlword + target torque at bytes 4*slot..4*slot+3 and UNSIGNED16 + INTEGER16 dummies
// (0006h, 0003h) for the others' (CiA 301 7.4.7.1; CiA 1301 for PDOs beyond 8 bytes). Two
// entries per drive in the 8 a mapping holds here (od::kPdoMaxMappedObjects): 4 drives, 16
// bytes. TPDO1 keeps kTpdo1Layout (6 bytes), sent as an FD frame. Slot out of range gives an
// all-dummy layout (count 0 when drives is out of 1..4).
inline constexpr std::uint8_t kFdRpdoNumber = kBroadcastRpdoNumber;
inline constexpr std::uint8_t kFdMaxDrives = od::kPdoMaxMappedObjects / 2;
constexpr PdoLayout fd_rpdo_layout(std::uint8_t slot, std::uint8_t drives) noexcept {
  PdoLayout l;
  if (drives < 1 || drives > kFdMaxDrives) return l;
  for (std::uint8_t i = 0; i < drives; ++i) {
    const bool own = i == slot;
    l.entries[2u * i] = own ? map_entry(od::kControlword) : dummy_entry(DataType::kUnsigned16);
    l.entries[2u * i + 1u] = own ? map_entry(od::kTargetTorque) : dummy_entry(DataType::kInteger16);
  }
  l.count = static_cast<std::uint8_t>(2 * drives);
  return l;
}

// Cyclic payload sizes in bytes, for the bus-load calculation.
constexpr std::uint8_t rpdo_bytes_per_drive() noexcept { return kRpdo1Layout.bytes(); }
constexpr std::uint8_t tpdo_bytes_per_drive() noexcept { return kTpdo1Layout.bytes(); }
constexpr std::uint8_t broadcast_rpdo_bytes(std::uint8_t drives) noexcept {
  return broadcast_rpdo_layout(0, drives).bytes();
}
constexpr std::uint8_t fd_rpdo_bytes(std::uint8_t drives) noexcept {
  return fd_rpdo_layout(0, drives).bytes();
}

// ---- codecs -----------------------------------------------------------------------------
struct DriveCommand {  // RPDO1, host -> drive
  std::uint16_t controlword = 0;
  std::int16_t target_torque = 0;  // per mille of rated torque (6076h)
  friend constexpr bool operator==(const DriveCommand&, const DriveCommand&) = default;
};
struct DriveFeedback {  // TPDO1, drive -> host
  std::uint16_t statusword = 0;
  std::int32_t position = 0;  // encoder counts (6064h)
  friend constexpr bool operator==(const DriveFeedback&, const DriveFeedback&) = default;
};
struct FdCommands {                                  // the CAN FD RPDO, host -> every drive
  std::array<DriveCommand, kFdMaxDrives> command{};  // by slot
  std::uint8_t drives = 0;
  friend constexpr bool operator==(const FdCommands&, const FdCommands&) = default;
};
struct BroadcastTorques {
  std::array<std::int16_t, kBroadcastMaxDrives> torque{};  // per mille, by slot
  std::uint8_t drives = 0;
  friend constexpr bool operator==(const BroadcastTorques&, const BroadcastTorques&) = default;
};

// Decoders: kWrongFunction, kWrongDlc (payload size of the layout), kRemoteFrame,
// kUnknownCobId, kExtendedId. Encoders: kBadNodeId.
Result<CanFrame> encode_rpdo1(std::uint8_t node, const DriveCommand& c) noexcept;
Result<DriveCommand> decode_rpdo1(const CanFrame& frame) noexcept;
Result<CanFrame> encode_tpdo1(std::uint8_t node, const DriveFeedback& f) noexcept;
Result<DriveFeedback> decode_tpdo1(const CanFrame& frame) noexcept;
// Node of a PDO frame (for dispatch before decoding); kWrongFunction for non-PDO ids.
Result<std::uint8_t> pdo_node(const CanFrame& frame) noexcept;

// Broadcast mode. drives 1..4 (kBadValue otherwise); DLC = 2 * drives.
Result<CanFrame> encode_broadcast_torques(const BroadcastTorques& t) noexcept;
Result<BroadcastTorques> decode_broadcast_torques(const CanFrame& frame) noexcept;
// What a drive in `slot` takes from the frame (its own two bytes); kWrongDlc when the
// frame is too short to hold the slot.
Result<std::int16_t> decode_broadcast_torque(const CanFrame& frame, std::uint8_t slot) noexcept;
// CAN FD mode. drives 1..4 (kBadValue otherwise); an FD frame with BRS, DLC = the FD size
// of 4 * drives bytes (fw::fd_frame_bytes). Decoders: kWrongDlc for a classic frame or one
// too short for the drives (or the slot).
Result<CanFrame> encode_fd_commands(const FdCommands& c) noexcept;
Result<FdCommands> decode_fd_commands(const CanFrame& frame, std::uint8_t drives) noexcept;
Result<DriveCommand> decode_fd_command(const CanFrame& frame, std::uint8_t slot) noexcept;
// TPDO1 of the CAN FD mode: kTpdo1Layout in an FD frame with BRS (decode_tpdo1 reads it).
Result<CanFrame> encode_fd_tpdo1(std::uint8_t node, const DriveFeedback& f) noexcept;
Result<CanFrame> encode_controlword_rpdo(std::uint8_t node, std::uint16_t controlword) noexcept;
Result<std::uint16_t> decode_controlword_rpdo(const CanFrame& frame) noexcept;
// TPDO1 of the broadcast mode (position, 4 B) and its TPDO3 (statusword, 2 B).
Result<CanFrame> encode_position_tpdo(std::uint8_t node, std::int32_t position) noexcept;
Result<std::int32_t> decode_position_tpdo(const CanFrame& frame) noexcept;
Result<CanFrame> encode_statusword_tpdo(std::uint8_t node, std::uint16_t statusword) noexcept;
Result<std::uint16_t> decode_statusword_tpdo(const CanFrame& frame) noexcept;

}  // namespace dualv::fw
