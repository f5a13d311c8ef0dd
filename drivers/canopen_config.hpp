#pragma once
// The `can:` section of the configuration (config/dualv.yaml): the CANopen bus description
// (its data: firmware_if/can_config.hpp), loaded and checked. Read by the host master
// (drivers/canopen_setup.hpp); the drive emulator (sim/) takes the same data.
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
#include "firmware_if/bus_layout.hpp"
#include "firmware_if/can_config.hpp"
#include "firmware_if/cia402.hpp"
#include "firmware_if/cob_id.hpp"
#include "firmware_if/pdo.hpp"
#include "firmware_if/sync.hpp"

namespace dualv::drivers {

// The bus description's data lives in firmware_if (firmware_if/can_config.hpp), so the
// drive emulator needs nothing of drivers but the bus interface; these are its names here.
using fw::BootObjects;
using fw::CanConfig;
using fw::CanDriveConfig;
using fw::ObjectPolicy;
using fw::OnExit;
using fw::to_string;

// The Dual-V default: four drives, node ids 1..4, the contract of docs/architecture.md.
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

// ---- bus load (docs/architecture.md "CAN contract", issue 15) --------------------------------
// The model is firmware_if/bus_layout.hpp (one owner); these give it the configuration.
fw::BusParams bus_params(const CanConfig& config) noexcept;
// Worst case of the configured layout at the SYNC rate: cyclic frames, and event PDOs
// (broadcast layout) at their inhibit-time bound.
fw::LayoutLoad bus_load_report(const CanConfig& config) noexcept;
// Printable, e.g.
//   "CAN bus load: 4 drives, per_drive layout, SYNC 0 B: 895 bits/cycle worst case; at
//    1000.0 Hz and 1000000 bit/s: 89.5 % cyclic (limit 90.0 %), 89.5 % with event PDOs at
//    their inhibit times (limit 95.0 %); max rate 1005.6 Hz"
std::string format_bus_load(const CanConfig& config, const fw::LayoutLoad& report);
// Throws ConfigError with the numbers when the worst case exceeds can.max_cyclic_load or
// can.max_bus_load, e.g. "can.sync.period: 2000.0 Hz with the per_drive layout needs 1790000
// bit/s worst case (895 bits/cycle) on a 1000000 bit/s bus: 179.0 % cyclic (...); lower the
// rate to at most 1005.6 Hz or use can.bus_layout: broadcast or fd (...)"; for the fd layout
// the demand is bus time: the arbitration phase at can.bitrate, the data phase at
// can.fd.data_bitrate.
fw::LayoutLoad require_bus_load_fits(const CanConfig& config);

}  // namespace dualv::drivers
