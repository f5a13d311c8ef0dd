#include "firmware_if/emcy.hpp"

#include "firmware_if/byte_order.hpp"
#include "firmware_if/cob_id.hpp"

namespace dualv::fw {

Result<CanFrame> encode_emcy(const Emcy& emcy) noexcept {
  if (!is_valid_node_id(emcy.node)) return Error::kBadNodeId;
  CanFrame f;
  f.id = cob_id(Function::kEmcy, emcy.node);
  f.dlc = 8;
  put_u16_le(&f.data[0], emcy.error_code);
  f.data[2] = emcy.error_register;
  for (std::size_t i = 0; i < emcy.manufacturer.size(); ++i) f.data[3 + i] = emcy.manufacturer[i];
  return f;
}

Result<Emcy> decode_emcy(const CanFrame& frame) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, Function::kEmcy);
  if (!node) return node.error();
  if (frame.dlc != 8) return Error::kWrongDlc;
  Emcy e;
  e.node = *node;
  e.error_code = get_u16_le(&frame.data[0]);
  e.error_register = frame.data[2];
  for (std::size_t i = 0; i < e.manufacturer.size(); ++i) e.manufacturer[i] = frame.data[3 + i];
  return e;
}

namespace {

struct CodeText {
  std::uint16_t code;
  const char* text;
};

// CiA 301 table 21 and CiA 402-2 error codes this stack meets.
constexpr CodeText kExact[] = {
    {emcy::kNoError, "error reset or no error"},
    {emcy::kGeneric, "generic error"},
    {emcy::kCurrent, "current"},
    {emcy::kContinuousOverCurrent, "continuous over-current"},
    {emcy::kShortCircuit, "short circuit / earth leakage (device output)"},
    {emcy::kVoltage, "voltage"},
    {emcy::kDcLinkOverVoltage, "DC link over-voltage"},
    {emcy::kDcLinkUnderVoltage, "DC link under-voltage"},
    {emcy::kTemperature, "temperature"},
    {emcy::kDeviceOverTemperature, "excess temperature, device"},
    {emcy::kMotorOverTemperature, "excess temperature, motor"},
    {emcy::kDeviceHardware, "device hardware"},
    {emcy::kDeviceSoftware, "device software"},
    {emcy::kAdditionalModules, "additional modules"},
    {emcy::kSensor, "sensor"},
    {emcy::kIncrementalSensorFault, "incremental sensor 1 fault (encoder)"},
    {emcy::kCommunication, "communication"},
    {emcy::kCanOverrun, "CAN overrun (objects lost)"},
    {emcy::kCanErrorPassive, "CAN in error passive mode"},
    {emcy::kHeartbeatError, "life guard or heartbeat error"},
    {emcy::kRecoveredFromBusOff, "recovered from bus-off"},
    {emcy::kPdoLengthError, "PDO not processed due to length error"},
    {emcy::kPdoLengthExceeded, "PDO length exceeded"},
    {emcy::kRpdoTimeout, "RPDO timeout"},
    {emcy::kFollowingError, "following error"},
    {emcy::kExternalError, "external error"},
    {emcy::kAdditionalFunctions, "additional functions"},
    {emcy::kDeviceSpecific, "device specific"},
};

// Classes by the code's high byte, then its high nibble (CiA 301 table 21).
constexpr CodeText kByHighByte[] = {
    {0x21, "current, device input side"},
    {0x22, "current inside the device"},
    {0x23, "current, device output side"},
    {0x31, "mains voltage"},
    {0x32, "voltage inside the device"},
    {0x33, "output voltage"},
    {0x41, "ambient temperature"},
    {0x42, "device temperature"},
    {0x81, "communication"},
    {0x82, "protocol error"},
    {0x83, "external error"},
    {0x86, "control (drive)"},
};
constexpr CodeText kByHighNibble[] = {
    {0x1, "generic error"},
    {0x2, "current"},
    {0x3, "voltage"},
    {0x4, "temperature"},
    {0x5, "device hardware"},
    {0x6, "device software"},
    {0x7, "additional modules"},
    {0x8, "monitoring"},
    {0x9, "external error"},
    {0xF, "additional functions / device specific"},
};

}  // namespace

const char* emcy_text(std::uint16_t error_code) noexcept {
  for (const CodeText& c : kExact)
    if (c.code == error_code) return c.text;
  for (const CodeText& c : kByHighByte)
    if (c.code == (error_code >> 8)) return c.text;
  for (const CodeText& c : kByHighNibble)
    if (c.code == (error_code >> 12)) return c.text;
  return "unknown error code";
}

}  // namespace dualv::fw
