#pragma once
// Electronic data sheet reader (CiA 306-1 v1.3 section 4: the INI-style EDS a drive vendor
// ships). Set-up code only: it allocates and throws EdsError (file:line: reason).
//
// What is read: object sections [1000], sub-index sections [1018sub0], [1018sub1]...
// (index and sub-index in hex), with the keys ParameterName, ObjectType (default 7 = VAR),
// DataType, AccessType (ro wo rw rwr rww const), PDOMapping (0/1), DefaultValue,
// SubNumber (ARRAY, RECORD, DEFSTRUCT), LowLimit, HighLimit; the object lists [MandatoryObjects],
// [OptionalObjects], [ManufacturerObjects] (SupportedObjects=n, 1=0x1000, ...). Numbers
// are decimal, hex (0x...) or octal (leading 0), negative for signed values; DefaultValue
// may add $NODEID (CiA 306 4.6.3.3: "$NODEID+0x180", "0x180+$NODEID").
// Other named sections ([FileInfo], [DeviceInfo], [Comments], [DummyUsage], vendor ones)
// are accepted and not interpreted; a section whose name starts with a hex digit must be
// an object or sub-index section (or CiA 306's [1018Name]/[1018Value]).
//
// Refused, with file and line: a section or key line that is not INI syntax, an unknown
// section name of index form, a duplicate section or key, a missing mandatory key, a bad
// number or access type, SubNumber different from the sub-index sections present, a
// sub-index section without its object, CompactSubObj (not supported), an object missing
// from the lists or listed without its section.
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "firmware_if/object_dictionary.hpp"

namespace dualv::fw::eds {

// CiA 301 7.4.3 table 42 object codes.
enum class ObjectType : std::uint8_t {
  kNull = 0x0,
  kDomain = 0x2,
  kDefType = 0x5,
  kDefStruct = 0x6,
  kVar = 0x7,
  kArray = 0x8,
  kRecord = 0x9,
};
const char* to_string(ObjectType t) noexcept;

// One (index, sub-index) of the EDS: a VAR object is its own sub-index 0.
struct EdsEntry {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  std::string name;             // ParameterName
  std::uint16_t data_type = 0;  // DataType: CiA 301 7.4.7.1 index (0007h = UNSIGNED32)
  Access access = Access::kRo;  // AccessType (rwr / rww read as rw)
  std::string access_text;      // as written, e.g. "rww"
  bool pdo_mappable = false;    // PDOMapping
  std::string default_value;    // DefaultValue as written ("" when absent)
  std::string low_limit;        // LowLimit ("" when absent)
  std::string high_limit;       // HighLimit ("" when absent)
  int line = 0;                 // of the section header

  // The firmware_if data type, when it is one the stack uses (BOOLEAN..UNSIGNED32).
  std::optional<DataType> type() const noexcept;
};

// One object (index) with its entries, sub-index order.
struct EdsObject {
  std::uint16_t index = 0;
  std::string name;
  ObjectType object_type = ObjectType::kVar;
  std::uint8_t sub_number = 0;  // SubNumber (ARRAY, RECORD, DEFSTRUCT); 0 otherwise
  std::vector<EdsEntry> entries;
  int line = 0;
};

enum class ObjectList : std::uint8_t { kMandatory, kOptional, kManufacturer };

struct Eds {
  std::string file;
  std::vector<EdsObject> objects;                                // in index order
  std::vector<std::uint16_t> mandatory, optional, manufacturer;  // the three lists

  const EdsObject* object(std::uint16_t index) const noexcept;
  const EdsEntry* entry(std::uint16_t index, std::uint8_t subindex) const noexcept;
};

class EdsError : public std::runtime_error {
 public:
  EdsError(const std::string& file, int line, const std::string& reason);
  const std::string& file() const noexcept { return file_; }
  int line() const noexcept { return line_; }

 private:
  std::string file_;
  int line_;
};

// Parses an EDS text; `file` names it in errors. Throws EdsError.
Eds parse_eds(std::string_view text, const std::string& file);
// Reads and parses a file; EdsError with line 0 when it cannot be read.
Eds read_eds_file(const std::string& path);

// A CiA 306 number: decimal, 0x hex, leading-0 octal, optional '-' (decimal). nullopt when
// it is none.
std::optional<std::int64_t> parse_number(std::string_view text) noexcept;
// The entry's DefaultValue for node `node_id` ($NODEID replaced), as the raw bit pattern in
// the entry's size (-1 in INTEGER16 is FFFFh). nullopt when there is no default or it is
// not a number (strings, REAL).
std::optional<std::uint32_t> default_value(const EdsEntry& e, std::uint8_t node_id) noexcept;

// "ro", "wo", "rw", "const".
const char* to_string(Access a) noexcept;
// "UNSIGNED32" for 0007h, "0021h" for a type without a name here.
std::string data_type_name(std::uint16_t data_type);

}  // namespace dualv::fw::eds
