#pragma once
// Emergency object (CiA 301 7.2.7): COB-ID 080h + node (1014h), DLC 8:
//   bytes 0..1 emergency error code (u16 LE), byte 2 error register (1001h),
//   bytes 3..7 manufacturer-specific error field.
// Error code 0000h means "error reset or no error": the producer left the error state.
// A consumer must clear the drive's fault on it, never raise one (docs/architecture.md, users #6).
#include <array>
#include <cstdint>

#include "firmware_if/can_frame.hpp"
#include "firmware_if/result.hpp"

namespace dualv::fw {

// Error codes used by the stack and the emulator (CiA 301 table 21, CiA 402-2 table for
// drives). Codes not listed still decode; emcy_text() then names the code's class.
namespace emcy {
inline constexpr std::uint16_t kNoError = 0x0000;  // error reset / no error
inline constexpr std::uint16_t kGeneric = 0x1000;
inline constexpr std::uint16_t kCurrent = 0x2000;
inline constexpr std::uint16_t kContinuousOverCurrent = 0x2310;
inline constexpr std::uint16_t kShortCircuit = 0x2320;
inline constexpr std::uint16_t kVoltage = 0x3000;
inline constexpr std::uint16_t kDcLinkOverVoltage = 0x3210;
inline constexpr std::uint16_t kDcLinkUnderVoltage = 0x3220;
inline constexpr std::uint16_t kTemperature = 0x4000;
inline constexpr std::uint16_t kDeviceOverTemperature = 0x4210;
inline constexpr std::uint16_t kMotorOverTemperature = 0x4310;
inline constexpr std::uint16_t kDeviceHardware = 0x5000;
inline constexpr std::uint16_t kDeviceSoftware = 0x6000;
inline constexpr std::uint16_t kAdditionalModules = 0x7000;
inline constexpr std::uint16_t kSensor = 0x7300;
inline constexpr std::uint16_t kIncrementalSensorFault = 0x7305;
inline constexpr std::uint16_t kCommunication = 0x8100;
inline constexpr std::uint16_t kCanOverrun = 0x8110;
inline constexpr std::uint16_t kCanErrorPassive = 0x8120;
inline constexpr std::uint16_t kHeartbeatError = 0x8130;  // life guard or heartbeat error
inline constexpr std::uint16_t kRecoveredFromBusOff = 0x8140;
inline constexpr std::uint16_t kPdoLengthError = 0x8210;  // PDO not processed: length error
inline constexpr std::uint16_t kPdoLengthExceeded = 0x8220;
inline constexpr std::uint16_t kRpdoTimeout = 0x8250;  // RPDO event timer (deadline) elapsed
inline constexpr std::uint16_t kFollowingError = 0x8611;
inline constexpr std::uint16_t kExternalError = 0x9000;  // e.g. the STO / e-stop input
inline constexpr std::uint16_t kAdditionalFunctions = 0xF000;
inline constexpr std::uint16_t kDeviceSpecific = 0xFF00;
}  // namespace emcy

// 1001h error register bits (CiA 301 7.5.2.2).
namespace error_register {
inline constexpr std::uint8_t kGeneric = 1u << 0;
inline constexpr std::uint8_t kCurrent = 1u << 1;
inline constexpr std::uint8_t kVoltage = 1u << 2;
inline constexpr std::uint8_t kTemperature = 1u << 3;
inline constexpr std::uint8_t kCommunication = 1u << 4;
inline constexpr std::uint8_t kDeviceProfile = 1u << 5;
inline constexpr std::uint8_t kManufacturer = 1u << 7;
}  // namespace error_register

struct Emcy {
  std::uint8_t node = 0;
  std::uint16_t error_code = emcy::kNoError;
  std::uint8_t error_register = 0;
  std::array<std::uint8_t, 5> manufacturer{};
  // 0000h: the error reset message. Clears the consumer's record of this node's error.
  constexpr bool is_reset() const noexcept { return error_code == emcy::kNoError; }
  friend constexpr bool operator==(const Emcy&, const Emcy&) = default;
};

// kBadNodeId when node is outside 1..127.
Result<CanFrame> encode_emcy(const Emcy& emcy) noexcept;
// kWrongFunction (incl. SYNC 080h, which has no node), kWrongDlc (not 8).
Result<Emcy> decode_emcy(const CanFrame& frame) noexcept;

// Readable text: the exact code when listed above, else its class from the high byte
// ("voltage", "communication", ...), else "unknown error code". Static storage.
const char* emcy_text(std::uint16_t error_code) noexcept;

}  // namespace dualv::fw
