#pragma once
// Boot sequence of the drives (not real-time), from the `can:` configuration:
//
//   1. NMT reset node, every configured node (CiA 301 7.2.8.3.1), then wait for each
//      node's boot-up message (700h + id, state 00h) within can.timeouts.boot. A node that
//      never boots is named in a BootTimeoutError: heartbeat consumers cannot see it.
//   2. Per node, in configuration order, in Pre-operational:
//      a. with check_drive_parameters: read 1000h (CiA 402 profile), 6502h (cyclic
//         synchronous torque supported), 6076h rated torque and 608Fh encoder resolution,
//         and refuse a mismatch with the configuration, naming the key;
//      b. the SDO writes of boot_writes(): each one read back and compared (a drive that
//         silently ignores a value is refused); an optional object the drive lacks is
//         skipped and reported (can.objects, drivers/canopen/README.md "Boot objects").
//   3. NMT start every node; wait until each heartbeat reports Operational (NMT is
//      unconfirmed: a node still not Operational after three heartbeat periods gets the
//      start command again, until can.timeouts.boot).
//
// Nothing is half-applied: on any error the nodes just configured are put back into
// Pre-operational (NMT) before the exception leaves, and the caller gets the error.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "drivers/canopen/master.hpp"
#include "drivers/canopen_config.hpp"
#include "firmware_if/object_dictionary.hpp"
#include "firmware_if/pdo.hpp"

namespace dualv::drivers::canopen {

// TPDO2 of the drives: the digital inputs 60FDh (the hardwired e-stop circuit is wired to
// od::kDigitalInputEstopBit), event driven.
inline constexpr std::uint8_t kDigitalInputsTpdo = 2;
inline constexpr fw::PdoLayout kDigitalInputsTpdoLayout{{fw::map_entry(fw::od::kDigitalInputs)}, 1};

// What boot reads from each drive when can.check_drive_parameters is set (step 2a), in this
// order: device type (CiA 402 profile), supported drive modes (cyclic synchronous torque),
// rated torque, encoder increments / motor revolutions. `dualv eds-check` checks the same list.
inline constexpr fw::OdEntry kParameterReads[] = {fw::od::kDeviceType, fw::od::kSupportedDriveModes,
                                                  fw::od::kRatedTorque, fw::od::kEncoderIncrements,
                                                  fw::od::kEncoderMotorRevolutions};

// One SDO write of the configuration (value as its raw bit pattern in the entry's size).
// Writes of a non-mandatory object carry its key in can.objects and its policy: when the
// drive answers 06020000h (no object), 06090011h (no sub-index) or, for a mapping entry,
// 06040041h (cannot be mapped) to an optional one, that write and the rest of the object's
// writes are skipped and reported; a required one fails the boot.
struct ConfigWrite {
  fw::OdEntry entry;
  std::uint32_t value = 0;
  const char* why = "";          // short reason, for logs and error messages
  const char* object = nullptr;  // can.objects key, nullptr = mandatory
  ObjectPolicy policy = ObjectPolicy::kRequired;
};

// An optional object boot left out, for the boot log.
struct SkippedObject {
  std::uint8_t node = 0;
  std::string object;  // can.objects key, e.g. "interpolation_period"
  std::string detail;  // "60C2h sub1 (interpolation time period value): 06020000h ..."
};
// "node 2: interpolation_period skipped (optional): 60C2h sub1 (...) aborted 06020000h ..."
std::string describe(const SkippedObject& s);

// The writes for drive `drive` (0..n-1), in the order they are sent:
//   1017h producer heartbeat time (ms);
//   cyclic RPDO (RPDO1 per-drive, RPDO2 broadcast or fd: fw::fd_rpdo_layout, 16 bytes for four
//   drives, in one CAN FD frame; RPDO1 is then left not valid) and, broadcast only, the
//   controlword RPDO1: COB-ID invalid, mapping count 0, mapping entries, count, transmission type,
//   event timer (deadline, 1400h sub5, on the cyclic RPDO), COB-ID valid (CiA 301 7.5.2.35:
//   a mapping is only changed while the PDO is invalid);
//   TPDO1: the same, transmission type 1 (every SYNC): statusword + position (per-drive, and
//   fd: sent as an FD frame) or position alone (broadcast); broadcast only, TPDO3 = statusword,
//   transmission type 255 (on change), inhibit time can.statusword_inhibit, event timer
//   can.statusword_refresh; TPDO2 (when can.digital_inputs_refresh > 0): 60FDh digital inputs,
//   transmission type 255 (on change), inhibit time 1 ms, event timer = the refresh; 6060h = 10
//   (cyclic synchronous torque), 6072h max torque (per mille of rated), 605Ah quick stop option,
//   605Eh fault reaction option, 6007h abort connection option, 1006h communication cycle period =
//   SYNC period (us), 60C2h interpolation period = SYNC period, 1019h SYNC counter overflow (when a
//   counter is used), 1016h sub1 consumer heartbeat of the master (last: from here on the drive
//   watches the host).
// Objects whose policy is off (can.objects) are left out.
std::vector<ConfigWrite> boot_writes(const CanConfig& config, int drive);

// 60C2h value/index for a period in ns: value * 10^index s (value 1..255). False when the
// period cannot be written exactly.
bool interpolation_period(std::uint64_t period_ns, std::uint8_t& value,
                          std::int8_t& index) noexcept;

// Runs the whole sequence above. A drive that aborts the write of a dummy mapping entry
// (broadcast and fd layouts) gets an SdoError naming the node, can.drives[i], the entry and
// the mapping object, and saying to use can.bus_layout: per_drive; one that aborts the FD
// RPDO's mapping count (more than 8 bytes: not a CAN FD device) an SdoError naming it and
// saying to use per_drive or broadcast.
// Throws BootTimeoutError, SdoError or CanopenError
// (what() names the node and the object), or ConfigError for a drive whose parameters do
// not match the configuration. Returns the optional objects skipped, each also given to
// `log` (one line each) when set.
std::vector<SkippedObject> boot_drives(CanopenMaster& master, const CanConfig& config,
                                       const std::function<void(const std::string&)>& log = {});

}  // namespace dualv::drivers::canopen
