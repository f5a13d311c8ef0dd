#pragma once
// Does a drive described by its EDS (CiA 306, firmware_if/eds.hpp) have what boot_drives()
// needs, before anything touches the bus (`dualv eds-check`)? Checked against the boot list
// itself (boot_writes(), kParameterReads in boot.hpp), for one drive of the `can:` config:
//   - every object boot writes is in the EDS, with the data type of firmware_if's object
//     dictionary and a writable access (rw / wo);
//   - every object boot reads (check_drive_parameters) is there and readable (ro / rw /
//     const); 1000h and 6502h defaults, when given, say CiA 402 and cyclic synchronous torque;
//   - every object the PDO mappings carry is there, PDO-mappable, of the mapped size, writable
//     when an RPDO carries it (6040h, 6071h) and readable when a TPDO does (6041h, 6064h, 60FDh);
//   - a non-mandatory object (can.objects) the drive lacks is skipped when its policy is
//     optional, a problem when required, with the safety consequence of skipping it;
//   - an object the EDS has without a sub-index any of the above needs is a problem whatever
//     its policy (an optional object is absent as a whole or present whole), named
//     file:line (the object's section), object and sub-index.
// Set-up code (allocates).
#include <string>
#include <vector>

#include "drivers/canopen_config.hpp"
#include "firmware_if/eds.hpp"

namespace dualv::drivers::canopen {

struct EdsCheckReport {
  std::uint8_t node = 0;
  std::vector<std::string> problems;  // each names the object and the reason: boot would fail
  std::vector<std::string> skipped;   // optional objects boot would skip, with why
  std::vector<std::string> notes;     // what skipping means for safety
  bool can_boot() const noexcept { return problems.empty(); }
};

// Drive `drive` (0..n-1) of `config` described by `eds` (defaults evaluated at its node id).
EdsCheckReport check_eds(const fw::eds::Eds& eds, const CanConfig& config, int drive);

}  // namespace dualv::drivers::canopen
