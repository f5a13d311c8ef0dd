#pragma once
// The CANopen bus description, the data of the `can:` section of the configuration
// (config/dualv.yaml), like ros2_canopen's bus.yml: what both ends of the wire agree on
// (node ids, layouts, periods, units, CiA 402 options, boot objects). Plain data, no I/O:
// the host reads it (drivers/canopen_config.hpp: the loader and its rules, with the key of
// every problem) and the drive emulator (sim/drive_emulator.hpp) takes its defaults from it,
// so sim depends on this file and the bus interface only. Times are nanoseconds here,
// seconds in the file.
#include <cstdint>
#include <string>
#include <vector>

#include "firmware_if/cia402.hpp"
#include "firmware_if/pdo.hpp"

namespace dualv::fw {

// What boot does with an object that CiA 301 / CiA 402 do not make mandatory for a cyclic
// synchronous torque drive (drivers/canopen/boot.hpp): write it and refuse a drive that
// lacks it (required), write it and skip it when the drive answers 06020000h / 06090011h
// (optional, printed in the boot log), or never touch it (off).
enum class ObjectPolicy : std::uint8_t { kRequired, kOptional, kOff };
constexpr const char* to_string(ObjectPolicy p) noexcept {
  switch (p) {
    case ObjectPolicy::kRequired:
      return "required";
    case ObjectPolicy::kOptional:
      return "optional";
    case ObjectPolicy::kOff:
      return "off";
  }
  return "?";
}

// The non-mandatory objects of the boot list, each with its policy (`can.objects` for every
// drive, `can.drives[i].objects` per drive; keys as below).
struct BootObjects {
  ObjectPolicy cycle_period = ObjectPolicy::kOptional;          // 1006h  cycle_period
  ObjectPolicy interpolation_period = ObjectPolicy::kOptional;  // 60C2h  interpolation_period
  ObjectPolicy abort_connection = ObjectPolicy::kRequired;      // 6007h  abort_connection
  ObjectPolicy quick_stop = ObjectPolicy::kRequired;            // 605Ah  quick_stop
  ObjectPolicy fault_reaction = ObjectPolicy::kRequired;        // 605Eh  fault_reaction
  ObjectPolicy consumer_heartbeat = ObjectPolicy::kRequired;    // 1016h  consumer_heartbeat
  ObjectPolicy digital_inputs = ObjectPolicy::kRequired;        // TPDO2 = 60FDh  digital_inputs
};

// Where boot leaves the drives when the process ends (CanopenActuatorSet::shut_down):
// voltage disabled in every case, then NMT pre-operational (PDOs stop, SDO stays), stopped
// (only NMT and heartbeat), or left operational with the voltage disabled.
enum class OnExit : std::uint8_t { kPreOperational, kStopped, kOperationalDisabled };
constexpr const char* to_string(OnExit e) noexcept {
  switch (e) {
    case OnExit::kPreOperational:
      return "preoperational";
    case OnExit::kStopped:
      return "stopped";
    case OnExit::kOperationalDisabled:
      return "operational_disabled";
  }
  return "?";
}

struct CanDriveConfig {
  std::uint8_t node_id = 1;
  std::uint32_t counts_per_revolution = 1u << 20;  // 608Fh increments / motor revolutions
  double rated_torque = 50.0;                      // [N m], the drive's 6076h (in mN m)
  double max_torque = 60.0;                        // [N m], written to 6072h (per mille)
  // [N m] the drive's peak torque (data sheet; in per mille of 6076h it bounds 6072h):
  // max_torque above it is refused.
  double peak_torque = 127.0;
  std::int32_t zero_offset = 0;  // [counts] encoder value at joint angle 0
  BootObjects objects{};         // can.objects, overridden by can.drives[i].objects
};

struct CanConfig {
  std::string interface = "vcan0";
  std::uint32_t bitrate = 1'000'000;       // [bit/s] nominal: classic frames, FD arbitration phase
  std::uint32_t data_bitrate = 5'000'000;  // [bit/s] can.fd.data_bitrate: FD data phase (BRS)
  double max_bus_load = 0.95;     // worst-case fraction accepted, event PDOs at their bound
  double max_cyclic_load = 0.90;  // ... for the cyclic frames alone (issue 15)
  BusLayout bus_layout = BusLayout::kPerDrive;  // can.bus_layout (firmware_if/pdo.hpp)
  // Broadcast layout only (firmware_if/pdo.hpp): the host sends a drive's controlword RPDO
  // when it changes, at most once per controlword_inhibit and at least once per
  // controlword_refresh; the drive sends its statusword TPDO3 on change, at most once per
  // statusword_inhibit (1802h sub3, 100 us units) and at least once per statusword_refresh
  // (1802h sub5, ms). So the host sees a drive's state at most statusword_inhibit + one cycle
  // after it changed, and hears it at least every statusword_refresh.
  std::uint64_t controlword_refresh_ns = 100'000'000;
  std::uint64_t controlword_inhibit_ns = 10'000'000;
  std::uint64_t statusword_inhibit_ns = 10'000'000;
  std::uint64_t statusword_refresh_ns = 100'000'000;

  std::uint64_t sync_period_ns = 1'000'000;  // = control period
  std::uint8_t sync_counter_overflow = 0;    // 0 or 2..240 (1019h)

  std::uint8_t master_node_id = 127;
  std::uint64_t master_heartbeat_period_ns = 50'000'000;

  std::uint64_t drive_heartbeat_period_ns = 50'000'000;     // drives' 1017h
  std::uint64_t drive_heartbeat_timeout_ns = 150'000'000;   // host-side consumer
  std::uint64_t master_heartbeat_timeout_ns = 150'000'000;  // drives' 1016h sub1
  std::uint64_t rpdo_deadline_ns = 10'000'000;              // 1400h sub5; 0 = off
  // TPDO2 = 60FDh digital inputs (the e-stop circuit), sent by the drive on change and at
  // least this often (1801h sub5 event timer); 0 = TPDO2 not configured.
  std::uint64_t digital_inputs_refresh_ns = 100'000'000;

  std::uint64_t sdo_timeout_ns = 100'000'000;
  std::uint64_t boot_timeout_ns = 5'000'000'000;
  std::uint64_t transition_timeout_ns = 500'000'000;
  std::uint32_t stale_cycles = 3;

  AbortConnectionOption abort_connection = AbortConnectionOption::kQuickStop;
  QuickStopOption quick_stop = QuickStopOption::kQuickStopRamp;
  FaultReactionOption fault_reaction = FaultReactionOption::kQuickStopRamp;
  bool check_drive_parameters = true;
  OnExit on_exit = OnExit::kPreOperational;  // can.on_exit

  std::vector<CanDriveConfig> drives;  // drive i = joint i; 1..drivers::kMaxDrives

  int size() const noexcept { return static_cast<int>(drives.size()); }
  double cycle_hz() const noexcept {
    return sync_period_ns ? 1e9 / static_cast<double>(sync_period_ns) : 0.0;
  }
  std::uint8_t sync_bytes() const noexcept { return sync_counter_overflow ? 1 : 0; }
  // Index of the drive with `node` (0..n-1), or -1.
  int drive_of_node(std::uint8_t node) const noexcept {
    for (std::size_t i = 0; i < drives.size(); ++i)
      if (drives[i].node_id == node) return static_cast<int>(i);
    return -1;
  }
};

}  // namespace dualv::fw
