#pragma once
// The emulated drive's object dictionary from an EDS (CiA 306, firmware_if/eds.hpp), for
// `dualv sim --eds FILE`: the EDS decides which of the emulator's objects the drive has
// (an EDS without 60C2h gives a drive without 60C2h), its identity (1018h sub1/sub2
// defaults), and every entry it has must be one the emulator implements, with the same
// data type, access and PDO mapping (differences()). Set-up code.
#include <cstdint>
#include <string>
#include <vector>

#include "firmware_if/eds.hpp"
#include "sim/canopen/object_dictionary.hpp"

namespace dualv::sim::canopen {

// The objects of firmware_if's dictionary (fw::od::kAll) that `eds` does not have: the
// emulator leaves them out (DriveEmulatorConfig::absent_objects, which refuses one a CiA 402
// drive cannot lack).
std::vector<std::uint16_t> objects_absent_from(const fw::eds::Eds& eds);

// What an EDS says of the drive to emulate: the objects it lacks (objects_absent_from) and
// its identity, 1018h sub1 vendor-ID and sub2 product code (their DefaultValue; `vendor_id`
// and `product_code` when the EDS gives none).
struct EdsDrive {
  std::vector<std::uint16_t> absent_objects;
  std::uint32_t vendor_id = 0;
  std::uint32_t product_code = 0;
};
EdsDrive drive_from_eds(const fw::eds::Eds& eds, std::uint32_t vendor_id,
                        std::uint32_t product_code);

// Every disagreement between `eds` and a built dictionary, both ways: an entry in one and
// not in the other, a different data type, access or PDO mapping. Each message names the
// entry and the EDS line; an object the EDS has without one of the dictionary's sub-indices
// is named "FILE:LINE: object IIIIh has no sub-index S" (`dualv sim --eds` refuses it rather
// than emulate the missing entry with the emulator's own). Empty when they agree.
std::vector<std::string> differences(const fw::eds::Eds& eds, const ObjectDictionary& od);

}  // namespace dualv::sim::canopen
