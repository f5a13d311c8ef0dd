// The EDS reader (firmware_if/eds.hpp, CiA 306) on any text: the input is the file (the
// shipped config/eds/dualv-emulated-drive.eds and damaged copies are the seeds), then what
// `dualv eds-check` (drivers/canopen/eds_check.hpp, against the shipped `can:` section) and
// `dualv sim --eds` (sim/canopen/eds_dictionary.hpp) do with an EDS that parses. A refusal is an
// EdsError (set-up code) naming "fuzz.eds:LINE" with a line of the input; everything else must
// not crash, leak, hang or hit undefined behaviour, and an EDS that parses must hold what
// eds.hpp promises, checked against the input text itself:
//   - objects in strictly ascending index order, each at a line of the input that is the
//     section header [IIII] of its index; entries in strictly ascending sub-index order, of
//     their object's index; a VAR (or NULL, DOMAIN, DEFTYPE) is its own sub-index 0, an
//     ARRAY, RECORD or DEFSTRUCT (a record type's definition, CiA 301 7.4.3) has SubNumber
//     entries (the campaign found this target asking it of ARRAY and RECORD only; seed
//     regression_defstruct_with_sub_indices.eds);
//   - every object in exactly one of [MandatoryObjects], [OptionalObjects],
//     [ManufacturerObjects], and every listed index an object; object()/entry() find each;
//   - a DefaultValue read as a number fits its entry's data type;
//   - eds-check's report names a node in each line; the objects `dualv sim --eds` leaves out
//     are exactly firmware_if's objects the EDS lacks.
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/canopen/eds_check.hpp"
#include "drivers/canopen_config.hpp"
#include "firmware_if/eds.hpp"
#include "firmware_if/object_dictionary.hpp"
#include "fuzz/check.hpp"
#include "sim/canopen/eds_dictionary.hpp"

namespace {

namespace eds = dualv::fw::eds;
namespace fw = dualv::fw;

// `s` without the white space (std::isspace: also \v, \f, \r) the EDS reader ignores around a
// line and inside a section header's brackets (firmware_if/eds.cpp).
std::string_view trimmed(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

// The lines of `text`: where each starts, so line n (1-based) is found without scanning the
// text again for every object (the scan per object made a large input quadratic).
class Lines {
 public:
  explicit Lines(std::string_view text) : text_(text) {
    starts_.push_back(0);
    for (std::size_t i = 0; i < text.size(); ++i)
      if (text[i] == '\n') starts_.push_back(i + 1);
  }
  int count() const { return static_cast<int>(starts_.size()); }
  // Line `n` (1-based), without its line ending and trimmed; "" past the end.
  std::string_view line(int n) const {
    if (n < 1 || n > count()) return {};
    const std::size_t start = starts_[static_cast<std::size_t>(n - 1)];
    return trimmed(text_.substr(start, text_.find('\n', start) - start));
  }

 private:
  std::string_view text_;
  std::vector<std::size_t> starts_;
};

// The index of a section header "[IIII]" (hex), or -1.
long section_index(std::string_view l) {
  if (l.size() < 3 || l.front() != '[' || l.back() != ']') return -1;
  const std::string hex(trimmed(l.substr(1, l.size() - 2)));
  if (hex.empty() || hex.find_first_not_of("0123456789abcdefABCDEF") != std::string::npos)
    return -1;
  return hex.size() > 8 ? -1 : static_cast<long>(std::strtoul(hex.c_str(), nullptr, 16));
}

const dualv::drivers::CanConfig& shipped_can() {
  static const dualv::drivers::CanConfig c =
      dualv::drivers::load_can_config_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  return c;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const Lines lines(text);
  eds::Eds e;
  try {
    e = eds::parse_eds(text, "fuzz.eds");
  } catch (const eds::EdsError& x) {
    FUZZ_CHECK(x.file() == "fuzz.eds");
    FUZZ_CHECK(x.line() >= 0 && x.line() <= lines.count() + 1);
    FUZZ_CHECK(std::string_view(x.what()).substr(0, 9) == "fuzz.eds:");
    return 0;
  }

  long previous = -1;
  for (const eds::EdsObject& o : e.objects) {
    FUZZ_CHECK(static_cast<long>(o.index) > previous);
    previous = o.index;
    FUZZ_CHECK(section_index(lines.line(o.line)) == static_cast<long>(o.index));
    FUZZ_CHECK(e.object(o.index) == &o);
    int listed = 0;
    for (const auto* list : {&e.mandatory, &e.optional, &e.manufacturer})
      listed += static_cast<int>(std::count(list->begin(), list->end(), o.index));
    FUZZ_CHECK(listed == 1);
    if (o.object_type == eds::ObjectType::kArray || o.object_type == eds::ObjectType::kRecord ||
        o.object_type == eds::ObjectType::kDefStruct)
      FUZZ_CHECK(o.entries.size() == o.sub_number);
    else
      FUZZ_CHECK(o.entries.size() == 1 && o.entries[0].subindex == 0);
    int sub = -1;
    for (const eds::EdsEntry& x : o.entries) {
      FUZZ_CHECK(x.index == o.index && static_cast<int>(x.subindex) > sub);
      sub = x.subindex;
      FUZZ_CHECK(e.entry(x.index, x.subindex) == &x);
      FUZZ_CHECK(x.line >= 1 && x.line <= lines.count());
      const auto t = x.type();
      const auto v = eds::default_value(x, 1);
      if (t && v && fw::size_of(*t) < 4) FUZZ_CHECK(*v >> (8 * fw::size_of(*t)) == 0);
    }
  }
  for (const auto* list : {&e.mandatory, &e.optional, &e.manufacturer})
    for (std::uint16_t index : *list) FUZZ_CHECK(e.object(index) != nullptr);

  // What eds-check and `dualv sim --eds` make of it.
  const dualv::drivers::CanConfig& can = shipped_can();
  for (int i = 0; i < can.size(); ++i) {
    const auto r = dualv::drivers::canopen::check_eds(e, can, i);
    FUZZ_CHECK(r.node == can.drives[static_cast<std::size_t>(i)].node_id);
    for (const auto* lines : {&r.problems, &r.skipped, &r.notes})
      for (const std::string& l : *lines) FUZZ_CHECK(l.rfind("node ", 0) == 0);
  }
  const auto absent = dualv::sim::canopen::objects_absent_from(e);
  for (const fw::OdEntry& entry : fw::od::kAll) {
    const bool out = std::find(absent.begin(), absent.end(), entry.index) != absent.end();
    FUZZ_CHECK(out ==
               std::none_of(e.objects.begin(), e.objects.end(),
                            [&](const eds::EdsObject& o) { return o.index == entry.index; }));
  }
  return 0;
}
