#pragma once
// The three bus layouts of issue 15 and their worst-case load (docs/architecture.md "CAN contract"
// and "Beating the naive bus limit"); frame sizes from firmware_if/can_frame_bits.hpp.
//
//   per-drive  SYNC, RPDO1 controlword + torque (4 B) and TPDO1 statusword + position (6 B)
//              per drive, every cycle: 55 + 4*95 + 4*115 = 895 bits for four drives.
//   broadcast  SYNC, one RPDO with every drive's torque (2 B each), TPDO position (4 B) per
//              drive every cycle: 55 + 135 + 4*95 = 570 bits; statusword (TPDO) and controlword
//              (RPDO) per drive as event PDOs, at most one per inhibit time (1800h/1400h sub3),
//              counted at that bound.
//   CAN FD     SYNC (classic), one FD RPDO with every drive's controlword + torque (4 B each,
//              16 B for four), one FD TPDO statusword + position (6 B) per drive, every cycle;
//              arbitration phase and frame tail at the nominal rate, data phase at the data
//              rate.
// Limits (issue 15): cyclic frames <= 90 % of the bus in the worst case, <= 95 % with the event
// frames at their bound. Heartbeats, EMCY and SDO are not cyclic and live in that margin.
#include <array>
#include <cstdint>

#include "firmware_if/can_frame_bits.hpp"
#include "firmware_if/pdo.hpp"

namespace dualv::fw {

struct BusParams {
  std::uint8_t drives = 4;
  std::uint32_t nominal_bitrate = 1'000'000;  // [bit/s] classic frames, FD arbitration phase
  std::uint32_t data_bitrate = 5'000'000;     // [bit/s] FD data phase
  std::uint8_t sync_bytes = 0;                // 1 with a SYNC counter (1019h)
  double statusword_inhibit_s = 0.010;        // broadcast: event TPDO, drive's 1800h sub3
  double controlword_inhibit_s = 0.010;       // broadcast: event RPDO, sent by the host
  double max_cyclic_load = 0.90;              // worst-case fraction for the cyclic frames
  double max_total_load = 0.95;               // ... with the event frames at their bound
};

// One kind of frame in a layout: `frames` of them every cycle, or (event frames) each at most
// once per `min_interval_s`.
struct TrafficItem {
  const char* what = "";
  std::uint8_t frames = 0;
  std::uint8_t bytes = 0;     // payload of one frame (FD: the DLC size)
  FrameBits bits{};           // worst case, one frame
  double min_interval_s = 0;  // 0 = cyclic
};
struct LayoutTraffic {
  std::array<TrafficItem, 5> items{};
  std::uint8_t count = 0;
  constexpr void add(const TrafficItem& t) noexcept {
    if (count < items.size()) items[count++] = t;
  }
};

constexpr std::uint8_t frames_for(std::uint8_t drives, std::uint8_t per_frame) noexcept {
  return static_cast<std::uint8_t>((drives + per_frame - 1) / per_frame);
}

constexpr LayoutTraffic layout_traffic(BusLayout layout, const BusParams& p) noexcept {
  LayoutTraffic t;
  t.add({"SYNC", 1, p.sync_bytes, classic_frame_bits(p.sync_bytes), 0});
  switch (layout) {
    case BusLayout::kPerDrive:
      t.add({"RPDO controlword + torque", p.drives, kRpdo1Layout.bytes(),
             classic_frame_bits(kRpdo1Layout.bytes()), 0});
      t.add({"TPDO statusword + position", p.drives, kTpdo1Layout.bytes(),
             classic_frame_bits(kTpdo1Layout.bytes()), 0});
      break;
    case BusLayout::kBroadcast: {
      // 4 torques per 8-byte frame; the last frame carries the rest.
      const std::uint8_t frames = frames_for(p.drives, 4);
      if (frames > 1)
        t.add({"RPDO torques", static_cast<std::uint8_t>(frames - 1), 8, classic_frame_bits(8), 0});
      if (frames > 0) {
        const auto bytes = static_cast<std::uint8_t>(2 * (p.drives - 4 * (frames - 1)));
        t.add({"RPDO torques", 1, bytes, classic_frame_bits(bytes), 0});
      }
      // The PDO layouts the master boots (firmware_if/pdo.hpp), so model and wire agree.
      t.add({"TPDO position", p.drives, kPositionTpdoLayout.bytes(),
             classic_frame_bits(kPositionTpdoLayout.bytes()), 0});
      t.add({"event TPDO statusword", p.drives, kStatuswordTpdoLayout.bytes(),
             classic_frame_bits(kStatuswordTpdoLayout.bytes()), p.statusword_inhibit_s});
      t.add({"event RPDO controlword", p.drives, kControlwordRpdoLayout.bytes(),
             classic_frame_bits(kControlwordRpdoLayout.bytes()), p.controlword_inhibit_s});
      break;
    }
    case BusLayout::kFd: {
      // 16 drives x 4 B per 64-byte frame (the master boots up to kFdMaxDrives in one frame:
      // firmware_if/pdo.hpp fd_rpdo_layout).
      const std::uint8_t frames = frames_for(p.drives, 16);
      if (frames > 1)
        t.add({"FD RPDO controlwords + torques", static_cast<std::uint8_t>(frames - 1), 64,
               fd_frame_bits(64), 0});
      if (frames > 0) {
        const auto bytes =
            fd_frame_bytes(static_cast<std::uint8_t>(4 * (p.drives - 16 * (frames - 1))));
        t.add({"FD RPDO controlwords + torques", 1, bytes, fd_frame_bits(bytes), 0});
      }
      t.add({"FD TPDO statusword + position", p.drives, kTpdo1Layout.bytes(),
             fd_frame_bits(kTpdo1Layout.bytes()), 0});
      break;
    }
  }
  return t;
}

struct LayoutLoad {
  BusLayout layout = BusLayout::kPerDrive;
  FrameBits cyclic_bits{};    // worst-case bits of the cyclic frames of one cycle
  double cycle_time_s = 0.0;  // their time on the bus
  double event_load = 0.0;    // fraction of the bus the event frames take at their bound
  double cyclic_load = 0.0;   // at the requested rate
  double total_load = 0.0;    // cyclic + event
  double full_rate_hz = 0.0;  // rate at which the bus is 100 % busy (events included)
  double max_rate_hz = 0.0;   // highest rate within both limits
  bool fits = false;          // both limits kept at the requested rate
};

constexpr LayoutLoad layout_load(BusLayout layout, const BusParams& p, double cycle_hz) noexcept {
  LayoutLoad r;
  r.layout = layout;
  const LayoutTraffic t = layout_traffic(layout, p);
  for (std::uint8_t i = 0; i < t.count; ++i) {
    const TrafficItem& it = t.items[i];
    const double s = it.frames * it.bits.seconds(p.nominal_bitrate, p.data_bitrate);
    if (it.min_interval_s > 0) {
      r.event_load += s / it.min_interval_s;
    } else {
      r.cyclic_bits.nominal += it.frames * it.bits.nominal;
      r.cyclic_bits.data += it.frames * it.bits.data;
      r.cycle_time_s += s;
    }
  }
  if (r.cycle_time_s <= 0.0) return r;
  r.cyclic_load = r.cycle_time_s * cycle_hz;
  r.total_load = r.cyclic_load + r.event_load;
  r.full_rate_hz = r.event_load < 1.0 ? (1.0 - r.event_load) / r.cycle_time_s : 0.0;
  const double by_cyclic = p.max_cyclic_load / r.cycle_time_s;
  const double by_total =
      p.max_total_load > r.event_load ? (p.max_total_load - r.event_load) / r.cycle_time_s : 0.0;
  r.max_rate_hz = by_cyclic < by_total ? by_cyclic : by_total;
  r.fits = cycle_hz > 0 && r.cyclic_load <= p.max_cyclic_load && r.total_load <= p.max_total_load;
  return r;
}

}  // namespace dualv::fw
