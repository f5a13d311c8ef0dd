#pragma once
// Worst-case CAN bus load of the cyclic traffic of the layout the CANopen master runs today
// (RpdoLayoutKind, firmware_if/pdo.hpp): one SYNC, the RPDO traffic, one TPDO1 (statusword +
// position) per drive; the controlword RPDO of the broadcast mode is sent on change and not
// counted here. Frame sizes: firmware_if/can_frame_bits.hpp. The three layouts of issue 15
// (with the event frames counted at their inhibit-time bound, and CAN FD) are modelled in
// firmware_if/bus_layout.hpp, which `dualv bus-load` prints side by side.
#include <cstdint>

#include "firmware_if/can_frame_bits.hpp"
#include "firmware_if/pdo.hpp"

namespace dualv::fw {

// Classic 11-bit frame: 47 + 8n + floor((34 + 8n - 1) / 4) bits.
constexpr std::uint32_t worst_case_frame_bits(std::uint8_t data_bytes) noexcept {
  return classic_frame_bits(data_bytes).total();
}
// 29-bit frames (for comparison): 67 + 8n + floor((54 + 8n - 1) / 4).
constexpr std::uint32_t worst_case_extended_frame_bits(std::uint8_t data_bytes) noexcept {
  return classic_extended_frame_bits(data_bytes).total();
}

// Worst-case bits of one control cycle for `drives` drives. sync_bytes: 0 (plain SYNC) or
// 1 (SYNC with counter). Broadcast: ceil(drives / 4) frames of up to four torques each.
// In broadcast mode the controlword RPDO is sent on change only and not counted.
constexpr std::uint32_t cycle_bits(std::uint8_t drives, RpdoLayoutKind layout,
                                   std::uint8_t sync_bytes = 0) noexcept {
  std::uint32_t bits = worst_case_frame_bits(sync_bytes);
  bits += drives * worst_case_frame_bits(tpdo_bytes_per_drive());
  if (layout == RpdoLayoutKind::kPerDrive) {
    bits += drives * worst_case_frame_bits(rpdo_bytes_per_drive());
  } else {
    std::uint8_t left = drives;
    while (left > 0) {
      const std::uint8_t in_frame = left > kBroadcastMaxDrives ? kBroadcastMaxDrives : left;
      bits += worst_case_frame_bits(broadcast_rpdo_bytes(in_frame));
      left = static_cast<std::uint8_t>(left - in_frame);
    }
  }
  return bits;
}

// Highest cycle rate the bus can carry (100 % worst-case load), in Hz.
constexpr double max_cycle_rate_hz(std::uint32_t bits_per_cycle, std::uint32_t bitrate) noexcept {
  return bits_per_cycle == 0 ? 0.0 : static_cast<double>(bitrate) / bits_per_cycle;
}
// Worst-case load fraction (1.0 = bus full) at `cycle_hz`.
constexpr double bus_load(std::uint32_t bits_per_cycle, double cycle_hz,
                          std::uint32_t bitrate) noexcept {
  return bitrate == 0 ? 0.0 : static_cast<double>(bits_per_cycle) * cycle_hz / bitrate;
}

// What the start-up report prints and the cycle-rate check refuses on.
struct BusLoadReport {
  RpdoLayoutKind layout = RpdoLayoutKind::kPerDrive;
  std::uint32_t bits_per_cycle = 0;
  double max_rate_hz = 0.0;
  double load = 0.0;  // at the requested rate
  bool fits = false;  // load <= max_load
};
constexpr BusLoadReport bus_load_report(std::uint8_t drives, RpdoLayoutKind layout, double cycle_hz,
                                        std::uint32_t bitrate, double max_load = 1.0,
                                        std::uint8_t sync_bytes = 0) noexcept {
  BusLoadReport r;
  r.layout = layout;
  r.bits_per_cycle = cycle_bits(drives, layout, sync_bytes);
  r.max_rate_hz = max_cycle_rate_hz(r.bits_per_cycle, bitrate);
  r.load = bus_load(r.bits_per_cycle, cycle_hz, bitrate);
  r.fits = bitrate != 0 && r.load <= max_load;
  return r;
}

}  // namespace dualv::fw
