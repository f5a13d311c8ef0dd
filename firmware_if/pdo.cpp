#include "firmware_if/pdo.hpp"

#include "firmware_if/byte_order.hpp"

namespace dualv::fw {

namespace {

Result<CanFrame> pdo_frame(Function f, std::uint8_t node, std::uint8_t dlc) noexcept {
  const Result<std::uint16_t> id = make_cob_id(f, node);
  if (!id) return id.error();
  CanFrame frame;
  frame.id = *id;
  frame.dlc = dlc;
  return frame;
}

// The byte offsets come from the layouts, so codec and mapping cannot disagree.
constexpr int kRpdoCwAt = kRpdo1Layout.offset_of(od::kControlword);
constexpr int kRpdoTorqueAt = kRpdo1Layout.offset_of(od::kTargetTorque);
constexpr int kTpdoSwAt = kTpdo1Layout.offset_of(od::kStatusword);
constexpr int kTpdoPosAt = kTpdo1Layout.offset_of(od::kPositionActual);
static_assert(kRpdoCwAt == 0 && kRpdoTorqueAt == 2 && kTpdoSwAt == 0 && kTpdoPosAt == 2);

}  // namespace

Result<CanFrame> encode_rpdo1(std::uint8_t node, const DriveCommand& c) noexcept {
  Result<CanFrame> r = pdo_frame(Function::kRpdo1, node, kRpdo1Layout.bytes());
  if (!r) return r;
  CanFrame f = *r;
  put_u16_le(&f.data[kRpdoCwAt], c.controlword);
  put_u16_le(&f.data[kRpdoTorqueAt], static_cast<std::uint16_t>(c.target_torque));
  return f;
}

Result<DriveCommand> decode_rpdo1(const CanFrame& frame) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, Function::kRpdo1);
  if (!node) return node.error();
  if (frame.dlc != kRpdo1Layout.bytes()) return Error::kWrongDlc;
  return DriveCommand{get_u16_le(&frame.data[kRpdoCwAt]),
                      as_i16(get_u16_le(&frame.data[kRpdoTorqueAt]))};
}

Result<CanFrame> encode_tpdo1(std::uint8_t node, const DriveFeedback& fb) noexcept {
  Result<CanFrame> r = pdo_frame(Function::kTpdo1, node, kTpdo1Layout.bytes());
  if (!r) return r;
  CanFrame f = *r;
  put_u16_le(&f.data[kTpdoSwAt], fb.statusword);
  put_u32_le(&f.data[kTpdoPosAt], static_cast<std::uint32_t>(fb.position));
  return f;
}

Result<DriveFeedback> decode_tpdo1(const CanFrame& frame) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, Function::kTpdo1);
  if (!node) return node.error();
  if (frame.dlc != kTpdo1Layout.bytes()) return Error::kWrongDlc;
  return DriveFeedback{get_u16_le(&frame.data[kTpdoSwAt]),
                       as_i32(get_u32_le(&frame.data[kTpdoPosAt]))};
}

Result<std::uint8_t> pdo_node(const CanFrame& frame) noexcept {
  const Result<CobIdInfo> info = classify(frame);
  if (!info) return info.error();
  switch (info->function) {
    case Function::kTpdo1:
    case Function::kTpdo2:
    case Function::kTpdo3:
    case Function::kTpdo4:
    case Function::kRpdo1:
    case Function::kRpdo2:
    case Function::kRpdo3:
    case Function::kRpdo4:
      return info->node;
    default:
      return Error::kWrongFunction;
  }
}

Result<CanFrame> encode_broadcast_torques(const BroadcastTorques& t) noexcept {
  if (t.drives < 1 || t.drives > kBroadcastMaxDrives) return Error::kBadValue;
  CanFrame f;
  f.id = kBroadcastRpdoCobId;
  f.dlc = broadcast_rpdo_bytes(t.drives);
  for (std::uint8_t i = 0; i < t.drives; ++i)
    put_u16_le(&f.data[2u * i], static_cast<std::uint16_t>(t.torque[i]));
  return f;
}

Result<BroadcastTorques> decode_broadcast_torques(const CanFrame& frame) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, Function::kBroadcastRpdo);
  if (!node) return node.error();
  if (frame.dlc < 2 || frame.dlc > 2 * kBroadcastMaxDrives || frame.dlc % 2 != 0)
    return Error::kWrongDlc;
  BroadcastTorques t;
  t.drives = static_cast<std::uint8_t>(frame.dlc / 2);
  for (std::uint8_t i = 0; i < t.drives; ++i) t.torque[i] = as_i16(get_u16_le(&frame.data[2u * i]));
  return t;
}

Result<std::int16_t> decode_broadcast_torque(const CanFrame& frame, std::uint8_t slot) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, Function::kBroadcastRpdo);
  if (!node) return node.error();
  if (slot >= kBroadcastMaxDrives) return Error::kBadValue;
  if (frame.dlc > 8 || frame.dlc < 2u * (slot + 1u)) return Error::kWrongDlc;
  return as_i16(get_u16_le(&frame.data[2u * slot]));
}

// The FD RPDO's byte offsets come from the mapping of slot 0 (then 4 bytes per slot).
constexpr auto kFdCwAt = static_cast<std::size_t>(fd_rpdo_layout(0, 1).offset_of(od::kControlword));
constexpr auto kFdTorqueAt =
    static_cast<std::size_t>(fd_rpdo_layout(0, 1).offset_of(od::kTargetTorque));
constexpr auto kFdSlotBytes = static_cast<std::size_t>(fd_rpdo_layout(0, 1).bytes());
static_assert(kFdCwAt == 0 && kFdTorqueAt == 2 && kFdSlotBytes == 4);
static_assert(static_cast<std::size_t>(fd_rpdo_layout(3, 4).offset_of(od::kControlword)) ==
              3 * kFdSlotBytes);

Result<CanFrame> encode_fd_commands(const FdCommands& c) noexcept {
  if (c.drives < 1 || c.drives > kFdMaxDrives) return Error::kBadValue;
  CanFrame f = data_frame(kBroadcastRpdoCobId, fd_rpdo_bytes(c.drives), true);
  for (std::uint8_t i = 0; i < c.drives; ++i) {
    put_u16_le(&f.data[kFdSlotBytes * i + kFdCwAt], c.command[i].controlword);
    put_u16_le(&f.data[kFdSlotBytes * i + kFdTorqueAt],
               static_cast<std::uint16_t>(c.command[i].target_torque));
  }
  return f;
}

Result<DriveCommand> decode_fd_command(const CanFrame& frame, std::uint8_t slot) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, Function::kBroadcastRpdo);
  if (!node) return node.error();
  if (slot >= kFdMaxDrives) return Error::kBadValue;
  if (!frame.fd || frame.dlc > kFdMaxBytes || frame.dlc < kFdSlotBytes * (slot + 1u))
    return Error::kWrongDlc;
  const std::size_t at = kFdSlotBytes * slot;
  return DriveCommand{get_u16_le(&frame.data[at + kFdCwAt]),
                      as_i16(get_u16_le(&frame.data[at + kFdTorqueAt]))};
}

Result<FdCommands> decode_fd_commands(const CanFrame& frame, std::uint8_t drives) noexcept {
  if (drives < 1 || drives > kFdMaxDrives) return Error::kBadValue;
  FdCommands c;
  c.drives = drives;
  for (std::uint8_t i = 0; i < drives; ++i) {
    const Result<DriveCommand> one = decode_fd_command(frame, i);
    if (!one) return one.error();
    c.command[i] = *one;
  }
  return c;
}

Result<CanFrame> encode_fd_tpdo1(std::uint8_t node, const DriveFeedback& fb) noexcept {
  Result<CanFrame> r = encode_tpdo1(node, fb);
  if (!r) return r;
  CanFrame f = *r;
  f.fd = true;
  f.brs = true;
  return f;
}

Result<CanFrame> encode_controlword_rpdo(std::uint8_t node, std::uint16_t controlword) noexcept {
  Result<CanFrame> r = pdo_frame(Function::kRpdo1, node, kControlwordRpdoLayout.bytes());
  if (!r) return r;
  CanFrame f = *r;
  put_u16_le(&f.data[0], controlword);
  return f;
}

Result<std::uint16_t> decode_controlword_rpdo(const CanFrame& frame) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, Function::kRpdo1);
  if (!node) return node.error();
  if (frame.dlc != kControlwordRpdoLayout.bytes()) return Error::kWrongDlc;
  return get_u16_le(&frame.data[0]);
}

Result<CanFrame> encode_position_tpdo(std::uint8_t node, std::int32_t position) noexcept {
  Result<CanFrame> r = pdo_frame(Function::kTpdo1, node, kPositionTpdoLayout.bytes());
  if (!r) return r;
  CanFrame f = *r;
  put_u32_le(&f.data[0], static_cast<std::uint32_t>(position));
  return f;
}

Result<std::int32_t> decode_position_tpdo(const CanFrame& frame) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, Function::kTpdo1);
  if (!node) return node.error();
  if (frame.dlc != kPositionTpdoLayout.bytes()) return Error::kWrongDlc;
  return as_i32(get_u32_le(&frame.data[0]));
}

Result<CanFrame> encode_statusword_tpdo(std::uint8_t node, std::uint16_t statusword) noexcept {
  Result<CanFrame> r =
      pdo_frame(tpdo_function(kStatuswordTpdoNumber), node, kStatuswordTpdoLayout.bytes());
  if (!r) return r;
  CanFrame f = *r;
  put_u16_le(&f.data[0], statusword);
  return f;
}

Result<std::uint16_t> decode_statusword_tpdo(const CanFrame& frame) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, tpdo_function(kStatuswordTpdoNumber));
  if (!node) return node.error();
  if (frame.dlc != kStatuswordTpdoLayout.bytes()) return Error::kWrongDlc;
  return get_u16_le(&frame.data[0]);
}

}  // namespace dualv::fw
