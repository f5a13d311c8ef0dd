#include "sim/canopen/eds_dictionary.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace dualv::sim::canopen {

namespace eds = fw::eds;

std::vector<std::uint16_t> objects_absent_from(const eds::Eds& e) {
  std::vector<std::uint16_t> absent;
  for (const fw::OdEntry& entry : fw::od::kAll)
    if (e.object(entry.index) == nullptr &&
        std::find(absent.begin(), absent.end(), entry.index) == absent.end())
      absent.push_back(entry.index);
  return absent;
}

EdsDrive drive_from_eds(const eds::Eds& e, std::uint32_t vendor_id, std::uint32_t product_code) {
  EdsDrive d{objects_absent_from(e), vendor_id, product_code};
  auto identity = [&e](const fw::OdEntry& which, std::uint32_t& out) {
    if (const eds::EdsEntry* x = e.entry(which.index, which.subindex))
      if (const auto v = eds::default_value(*x, 0)) out = *v;
  };
  identity(fw::od::kIdentityVendorId, d.vendor_id);
  identity(fw::od::kIdentityProductCode, d.product_code);
  return d;
}

std::vector<std::string> differences(const eds::Eds& e, const ObjectDictionary& od) {
  std::vector<std::string> d;
  for (std::size_t slot = 0; slot < od.size(); ++slot) {
    const fw::OdEntry& o = od.entry(static_cast<int>(slot));
    const eds::EdsEntry* x = e.entry(o.index, o.subindex);
    if (x == nullptr) {
      // An object the EDS has, but not whole: refused rather than emulated with the
      // emulator's own entry (a drive is built from its EDS, not completed by defaults).
      if (const eds::EdsObject* obj = e.object(o.index))
        d.push_back(
            fmt::format("{}:{}: object {:04X}h has no sub-index {} ({}): the emulated "
                        "drive needs it; describe the object whole in the EDS",
                        e.file, obj->line, o.index, o.subindex, o.name));
      else
        d.push_back(fmt::format("{:04X}h sub{} ({}): in the emulator, not in {}", o.index,
                                o.subindex, o.name, e.file));
      continue;
    }
    const auto where =
        fmt::format("{}:{}: {:04X}h sub{} ({})", e.file, x->line, o.index, o.subindex, o.name);
    if (x->type() != o.type)
      d.push_back(fmt::format("{}: DataType {} in the EDS, {} in the emulator", where,
                              eds::data_type_name(x->data_type),
                              eds::data_type_name(static_cast<std::uint16_t>(o.type))));
    if (x->access != o.access)
      d.push_back(fmt::format("{}: AccessType {} in the EDS, {} in the emulator", where,
                              eds::to_string(x->access), eds::to_string(o.access)));
    if (x->pdo_mappable != o.pdo_mappable)
      d.push_back(fmt::format("{}: PDOMapping={} in the EDS, {} in the emulator", where,
                              x->pdo_mappable ? 1 : 0, o.pdo_mappable ? 1 : 0));
  }
  for (const eds::EdsObject& obj : e.objects)
    for (const eds::EdsEntry& x : obj.entries)
      if (od.find(x.index, x.subindex) < 0)
        d.push_back(fmt::format("{}:{}: {:04X}h sub{} ({}): in the EDS, not in the emulator{}",
                                e.file, x.line, x.index, x.subindex, x.name,
                                od.has_index(x.index) ? "" : " (an object it does not implement)"));
  return d;
}

}  // namespace dualv::sim::canopen
