#pragma once
// The object-dictionary entries the stack uses (CiA 301 communication profile, CiA 402
// drive profile). This is the only file in the code base where an index is written; the
// host drivers (SDO configuration, PDO mapping) and the drive emulator (its SDO server's
// dictionary) both take them from here.
#include <cstdint>

namespace dualv::fw {

// CiA 301 7.4.7.1 static data types; the value is the type's own index (0001h..0007h),
// which is also the index used for dummy entries in a PDO mapping.
enum class DataType : std::uint8_t {
  kBoolean = 0x01,
  kInteger8 = 0x02,
  kInteger16 = 0x03,
  kInteger32 = 0x04,
  kUnsigned8 = 0x05,
  kUnsigned16 = 0x06,
  kUnsigned32 = 0x07,
};

// Size on the wire in bytes (BOOLEAN travels as one byte in SDO).
constexpr std::uint8_t size_of(DataType t) noexcept {
  switch (t) {
    case DataType::kBoolean:
    case DataType::kInteger8:
    case DataType::kUnsigned8:
      return 1;
    case DataType::kInteger16:
    case DataType::kUnsigned16:
      return 2;
    case DataType::kInteger32:
    case DataType::kUnsigned32:
      return 4;
  }
  return 0;
}
constexpr bool is_signed(DataType t) noexcept {
  return t == DataType::kInteger8 || t == DataType::kInteger16 || t == DataType::kInteger32;
}

// CiA 301 7.4.5 access attributes.
enum class Access : std::uint8_t { kRo, kWo, kRw, kConst };

// One (index, subindex) entry.
struct OdEntry {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  DataType type = DataType::kUnsigned8;
  Access access = Access::kRo;
  bool pdo_mappable = false;
  const char* name = "";

  constexpr std::uint8_t size() const noexcept { return size_of(type); }
  constexpr std::uint8_t bits() const noexcept { return static_cast<std::uint8_t>(8 * size()); }
  // The same object at another subindex (records and arrays).
  constexpr OdEntry at(std::uint8_t sub, DataType t, Access a) const noexcept {
    return OdEntry{index, sub, t, a, pdo_mappable, name};
  }
  constexpr bool same_object(std::uint16_t i, std::uint8_t s) const noexcept {
    return index == i && subindex == s;
  }
};

namespace od {

using enum DataType;
using enum Access;

// ---- CiA 301 communication profile area (1000h..1FFFh) --------------------------------
inline constexpr OdEntry kDeviceType{0x1000, 0, kUnsigned32, kRo, false, "device type"};
// 1000h low word 0x0192 = 402: the device follows CiA 402 (checked at boot).
inline constexpr std::uint16_t kDeviceProfileCia402 = 402;
inline constexpr OdEntry kErrorRegister{0x1001, 0, kUnsigned8, kRo, true, "error register"};
inline constexpr OdEntry kCobIdSync{0x1005, 0, kUnsigned32, kRw, false, "COB-ID SYNC"};
inline constexpr OdEntry kCommunicationCyclePeriod{
    0x1006, 0, kUnsigned32, kRw, false, "communication cycle period (us)"};
inline constexpr OdEntry kCobIdEmcy{0x1014, 0, kUnsigned32, kRw, false, "COB-ID EMCY"};
// 1016h is an array: sub0 = number of entries (u8), sub1..n = u32 (node << 16 | time ms),
// see heartbeat.hpp consumer_heartbeat_value().
inline constexpr OdEntry kConsumerHeartbeatCount{0x1016, 0,     kUnsigned8,
                                                 kRo,    false, "consumer heartbeat time"};
constexpr OdEntry consumer_heartbeat(std::uint8_t sub) noexcept {
  return OdEntry{0x1016, sub, kUnsigned32, kRw, false, "consumer heartbeat time"};
}
inline constexpr OdEntry kProducerHeartbeat{0x1017, 0,     kUnsigned16,
                                            kRw,    false, "producer heartbeat time (ms)"};
// 1018h identity: sub0 highest sub-index supported, sub1 vendor id, sub2 product code,
// sub3 revision, sub4 serial.
inline constexpr OdEntry kIdentityCount{0x1018, 0,     kUnsigned8,
                                        kConst, false, "identity: highest sub-index supported"};
inline constexpr OdEntry kIdentityVendorId{0x1018, 1, kUnsigned32, kRo, false, "vendor-ID"};
inline constexpr OdEntry kIdentityProductCode{0x1018, 2, kUnsigned32, kRo, false, "product code"};
inline constexpr OdEntry kIdentityRevision{0x1018, 3, kUnsigned32, kRo, false, "revision number"};
inline constexpr OdEntry kIdentitySerial{0x1018, 4, kUnsigned32, kRo, false, "serial number"};
// 1019h: SYNC counter overflow value; 0 = SYNC without counter (DLC 0), 2..240 = counter.
inline constexpr OdEntry kSyncCounterOverflow{0x1019, 0,     kUnsigned8,
                                              kRw,    false, "synchronous counter overflow value"};

// PDO parameters (CiA 301 7.5.2.35..7.5.2.38). RPDO n (1..4): 1400h+n-1 communication,
// 1600h+n-1 mapping; TPDO n: 1800h+n-1 and 1A00h+n-1.
enum class PdoDirection : std::uint8_t { kRpdo, kTpdo };
inline constexpr std::uint16_t kRpdoCommunicationBase = 0x1400;
inline constexpr std::uint16_t kRpdoMappingBase = 0x1600;
inline constexpr std::uint16_t kTpdoCommunicationBase = 0x1800;
inline constexpr std::uint16_t kTpdoMappingBase = 0x1A00;
// Communication record subindices (sub0: highest sub-index supported, u8 const).
inline constexpr std::uint8_t kPdoSubCobId = 1;             // u32, see pdo.hpp pdo_cob_id_value
inline constexpr std::uint8_t kPdoSubTransmissionType = 2;  // u8, see pdo.hpp kTransmission*
inline constexpr std::uint8_t kPdoSubInhibitTime = 3;       // u16, 100 us units (TPDO)
inline constexpr std::uint8_t kPdoSubEventTimer = 5;        // u16 ms; RPDO: deadline monitoring
// Mapping record: sub0 = number of mapped objects (u8, 0 disables), sub1..8 u32 entries.
inline constexpr std::uint8_t kPdoMaxMappedObjects = 8;

constexpr std::uint16_t pdo_communication_index(PdoDirection d, std::uint8_t pdo_number) noexcept {
  return static_cast<std::uint16_t>(
      (d == PdoDirection::kRpdo ? kRpdoCommunicationBase : kTpdoCommunicationBase) + pdo_number -
      1);
}
constexpr std::uint16_t pdo_mapping_index(PdoDirection d, std::uint8_t pdo_number) noexcept {
  return static_cast<std::uint16_t>(
      (d == PdoDirection::kRpdo ? kRpdoMappingBase : kTpdoMappingBase) + pdo_number - 1);
}
// Sub0 of a communication record: the highest sub-index the device supports (CiA 301
// 7.5.2.35 / 7.5.2.37), 5 when the event timer is the last one implemented.
constexpr OdEntry pdo_communication_count(PdoDirection d, std::uint8_t n) noexcept {
  return OdEntry{pdo_communication_index(d, n),
                 0,
                 kUnsigned8,
                 kConst,
                 false,
                 "PDO communication: highest sub-index supported"};
}
constexpr OdEntry pdo_cob_id(PdoDirection d, std::uint8_t n) noexcept {
  return OdEntry{
      pdo_communication_index(d, n), kPdoSubCobId, kUnsigned32, kRw, false, "PDO COB-ID"};
}
constexpr OdEntry pdo_transmission_type(PdoDirection d, std::uint8_t n) noexcept {
  return OdEntry{pdo_communication_index(d, n), kPdoSubTransmissionType, kUnsigned8, kRw, false,
                 "PDO transmission type"};
}
constexpr OdEntry pdo_inhibit_time(PdoDirection d, std::uint8_t n) noexcept {
  return OdEntry{pdo_communication_index(d, n),
                 kPdoSubInhibitTime,
                 kUnsigned16,
                 kRw,
                 false,
                 "PDO inhibit time"};
}
constexpr OdEntry pdo_event_timer(PdoDirection d, std::uint8_t n) noexcept {
  return OdEntry{
      pdo_communication_index(d, n), kPdoSubEventTimer, kUnsigned16, kRw, false, "PDO event timer"};
}
constexpr OdEntry pdo_mapping_count(PdoDirection d, std::uint8_t n) noexcept {
  return OdEntry{pdo_mapping_index(d, n), 0, kUnsigned8, kRw, false, "PDO number of mapped"};
}
// sub = 1..8
constexpr OdEntry pdo_mapping_entry(PdoDirection d, std::uint8_t n, std::uint8_t sub) noexcept {
  return OdEntry{pdo_mapping_index(d, n), sub, kUnsigned32, kRw, false, "PDO mapping entry"};
}

// ---- CiA 402 drive profile area (6000h..67FFh, first axis) ----------------------------
// 6007h abort connection option code, values in cia402.hpp AbortConnectionOption.
inline constexpr OdEntry kAbortConnectionOption{0x6007, 0,     kInteger16,
                                                kRw,    false, "abort connection option code"};
inline constexpr OdEntry kErrorCode{0x603F, 0, kUnsigned16, kRo, true, "error code"};
inline constexpr OdEntry kControlword{0x6040, 0, kUnsigned16, kRw, true, "controlword"};
inline constexpr OdEntry kStatusword{0x6041, 0, kUnsigned16, kRo, true, "statusword"};
// 605Ah..605Eh option codes, values in cia402.hpp.
inline constexpr OdEntry kQuickStopOption{0x605A, 0,     kInteger16,
                                          kRw,    false, "quick stop option code"};
inline constexpr OdEntry kShutdownOption{0x605B, 0, kInteger16, kRw, false, "shutdown option code"};
inline constexpr OdEntry kDisableOperationOption{0x605C, 0,     kInteger16,
                                                 kRw,    false, "disable operation option code"};
inline constexpr OdEntry kHaltOption{0x605D, 0, kInteger16, kRw, false, "halt option code"};
inline constexpr OdEntry kFaultReactionOption{0x605E, 0,     kInteger16,
                                              kRw,    false, "fault reaction option code"};
inline constexpr OdEntry kModesOfOperation{0x6060, 0, kInteger8, kRw, true, "modes of operation"};
inline constexpr OdEntry kModesOfOperationDisplay{0x6061, 0,    kInteger8,
                                                  kRo,    true, "modes of operation display"};
// Position in encoder counts ("position units" with 608Fh as factor 1).
inline constexpr OdEntry kPositionActual{0x6064, 0, kInteger32, kRo, true, "position actual value"};
// Velocity in counts per second (velocity units, factor 1).
inline constexpr OdEntry kVelocityActual{0x606C, 0, kInteger32, kRo, true, "velocity actual value"};
// Torques 6071h/6072h/6077h in per mille of rated torque 6076h (CiA 402-2 6.x torque).
inline constexpr OdEntry kTargetTorque{0x6071, 0, kInteger16, kRw, true, "target torque"};
inline constexpr OdEntry kMaxTorque{0x6072, 0, kUnsigned16, kRw, true, "max torque"};
inline constexpr OdEntry kRatedTorque{0x6076, 0,     kUnsigned32,
                                      kRw,    false, "motor rated torque (mN m)"};
inline constexpr OdEntry kTorqueActual{0x6077, 0, kInteger16, kRo, true, "torque actual value"};
// 608Fh position encoder resolution = encoder increments (sub1) / motor revolutions (sub2);
// sub0 = 2, the highest sub-index (a record, CiA 402-2).
inline constexpr OdEntry kEncoderResolutionCount{
    0x608F, 0, kUnsigned8, kConst, false, "position encoder resolution: highest sub-index"};
inline constexpr OdEntry kEncoderIncrements{
    0x608F, 1, kUnsigned32, kRw, false, "position encoder resolution: encoder increments"};
inline constexpr OdEntry kEncoderMotorRevolutions{
    0x608F, 2, kUnsigned32, kRw, false, "position encoder resolution: motor revs"};
// 60C2h interpolation time period: value (sub1, u8) x 10^index (sub2, i8) s; the cyclic
// synchronous modes use it as the expected SYNC period. sub0 = 2 (a record).
inline constexpr OdEntry kInterpolationPeriodCount{
    0x60C2, 0, kUnsigned8, kConst, false, "interpolation time period: highest sub-index"};
inline constexpr OdEntry kInterpolationPeriodValue{
    0x60C2, 1, kUnsigned8, kRw, false, "interpolation time period value"};
inline constexpr OdEntry kInterpolationPeriodIndex{0x60C2, 2,     kInteger8,
                                                   kRw,    false, "interpolation time index"};
// 60FDh digital inputs: bit 0 negative limit, 1 positive limit, 2 home, 3 interlock,
// 16..31 manufacturer specific.
inline constexpr OdEntry kDigitalInputs{0x60FD, 0, kUnsigned32, kRo, true, "digital inputs"};
// The e-stop circuit (hardwired to STO) is wired back to this input, so software sees
// it (docs/architecture.md "Safety"). A manufacturer-specific bit: configurable, this is the
// default.
inline constexpr std::uint32_t kDigitalInputEstopBit = 16;
inline constexpr std::uint32_t kDigitalInputEstopMask = 1u << kDigitalInputEstopBit;
// 6502h supported drive modes: bit (mode - 1) set for each mode; bit 9 = CST.
inline constexpr OdEntry kSupportedDriveModes{0x6502, 0,     kUnsigned32,
                                              kRo,    false, "supported drive modes"};

// Every fixed entry above, for the emulator's dictionary and for table-driven tests.
inline constexpr OdEntry kAll[] = {
    kDeviceType,
    kErrorRegister,
    kCobIdSync,
    kCommunicationCyclePeriod,
    kCobIdEmcy,
    kConsumerHeartbeatCount,
    kProducerHeartbeat,
    kIdentityCount,
    kIdentityVendorId,
    kIdentityProductCode,
    kIdentityRevision,
    kIdentitySerial,
    kSyncCounterOverflow,
    kAbortConnectionOption,
    kErrorCode,
    kControlword,
    kStatusword,
    kQuickStopOption,
    kShutdownOption,
    kDisableOperationOption,
    kHaltOption,
    kFaultReactionOption,
    kModesOfOperation,
    kModesOfOperationDisplay,
    kPositionActual,
    kVelocityActual,
    kTargetTorque,
    kMaxTorque,
    kRatedTorque,
    kTorqueActual,
    kEncoderResolutionCount,
    kEncoderIncrements,
    kEncoderMotorRevolutions,
    kInterpolationPeriodCount,
    kInterpolationPeriodValue,
    kInterpolationPeriodIndex,
    kDigitalInputs,
    kSupportedDriveModes,
};

}  // namespace od
}  // namespace dualv::fw
