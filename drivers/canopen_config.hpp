#pragma once
// The `can:` section of the configuration (config/dualv.yaml): the CANopen bus description,
// like ros2_canopen's bus.yml. Read by the host master (drivers/canopen_setup.hpp) and by the
// drive emulator (sim/), so both ends agree on node ids, layouts, periods and units.
//
// load_can_config() is set-up code: it reads every key strictly (unknown keys, wrong types,
// values out of range are errors naming the key, e.g. "can.drives[2].node_id: 3 is used
// twice"), collects every problem and throws dualv::ConfigError listing them all. It never
// returns a half-checked configuration. Times are seconds in the file and nanoseconds here.
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <string>
#include <vector>

#include "drivers/actuator_set.hpp"
#include "firmware_if/bus_load.hpp"
#include "firmware_if/cia402.hpp"
#include "firmware_if/cob_id.hpp"
#include "firmware_if/pdo.hpp"
#include "firmware_if/sync.hpp"

namespace dualv::drivers {

// What boot does with an object that CiA 301 / CiA 402 do not make mandatory for a cyclic
// synchronous torque drive (drivers/canopen/boot.hpp): write it and refuse a drive that
// lacks it (required), write it and skip it when the drive answers 06020000h / 06090011h
// (optional, printed in the boot log), or never touch it (off).
enum class ObjectPolicy : std::uint8_t { kRequired, kOptional, kOff };
const char* to_string(ObjectPolicy p) noexcept;

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
const char* to_string(OnExit e) noexcept;

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
  std::uint32_t bitrate = 1'000'000;  // [bit/s]
  double max_bus_load = 0.95;         // worst-case fraction accepted
  fw::RpdoLayoutKind rpdo_layout = fw::RpdoLayoutKind::kPerDrive;
  std::uint64_t controlword_refresh_ns = 100'000'000;  // broadcast layout only

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

  fw::AbortConnectionOption abort_connection = fw::AbortConnectionOption::kQuickStop;
  fw::QuickStopOption quick_stop = fw::QuickStopOption::kQuickStopRamp;
  fw::FaultReactionOption fault_reaction = fw::FaultReactionOption::kQuickStopRamp;
  bool check_drive_parameters = true;
  OnExit on_exit = OnExit::kPreOperational;  // can.on_exit

  std::vector<CanDriveConfig> drives;  // drive i = joint i; 1..kMaxDrives

  int size() const noexcept { return static_cast<int>(drives.size()); }
  double cycle_hz() const noexcept { return sync_period_ns ? 1e9 / sync_period_ns : 0.0; }
  std::uint8_t sync_bytes() const noexcept { return sync_counter_overflow ? 1 : 0; }
  // Index of the drive with `node` (0..n-1), or -1.
  int drive_of_node(std::uint8_t node) const noexcept;
};

// The Dual-V default: four drives, node ids 1..4, the contract of DESIGN.md.
CanConfig default_can_config();

// Reads the `can:` node (the section itself, e.g. root["can"]). An absent section gives
// default_can_config(). Throws dualv::ConfigError naming every bad key. `safety_torque_max`
// [N m] (the `safety.torque.max` of the same file, 0 = not checked): a
// can.drives[].max_torque above it is refused.
CanConfig load_can_config(const YAML::Node& can_node, double safety_torque_max = 0.0);
// Same, from a file's `can:` section, checked against the file's `safety.torque.max`.
CanConfig load_can_config_file(const std::string& path);
// `safety.torque.max` of a configuration root (the safety layer's default, 60 N m, when the
// key is absent); only read here to bound can.drives[].max_torque.
double safety_torque_max_of(const YAML::Node& root);
// Throws ConfigError naming can.drives[i].max_torque when it exceeds the drive's peak
// (can.drives[i].peak_torque, as per mille of 6076h) or `safety_torque_max` (> 0).
void check_torque_limits(const CanConfig& config, double safety_torque_max);
// Re-checks a configuration built in code (the same rules as the loader); throws ConfigError.
void validate(const CanConfig& config);
// Throws ConfigError ("can.sync.period: 0.002 s but the control period is 0.001 s") when the
// SYNC period differs from the control loop's period (loop.rate_hz).
void check_sync_period(const CanConfig& config, double control_period_s);

// ---- bus load (DESIGN.md "CAN contract") -----------------------------------------------
// Worst-case bits per cycle for the configured drives, layout, SYNC and rate.
fw::BusLoadReport bus_load_report(const CanConfig& config) noexcept;
// Printable, e.g.
//   "CAN bus load: 4 drives, per-drive RPDO (...), SYNC 0 B: 895 bits/cycle worst case;
//    at 1000 Hz and 1000000 bit/s: 89.5 % (limit 95.0 %); max rate 1117.3 Hz"
std::string format_bus_load(const CanConfig& config, const fw::BusLoadReport& report);
// Throws ConfigError with both numbers when the worst case exceeds max_bus_load, e.g.
//   "can.sync.period: 2000 Hz needs 1790000 bit/s worst case (895 bits/cycle) but the bus
//    carries 1000000 bit/s x 95 % = 950000 bit/s; lower the rate below 1061.5 Hz or use
//    rpdo_layout: broadcast"
fw::BusLoadReport require_bus_load_fits(const CanConfig& config);

}  // namespace dualv::drivers
