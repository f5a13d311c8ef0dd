#include "sim/canopen/object_dictionary.hpp"

#include <algorithm>
#include <stdexcept>

namespace dualv::sim::canopen {

int ObjectDictionary::add(const fw::OdEntry& e, std::uint32_t initial) {
  if (std::find(absent_.begin(), absent_.end(), e.index) != absent_.end()) return -1;
  if (find(e) >= 0) throw std::logic_error("object dictionary: entry added twice");
  if (count_ >= slots_.size()) throw std::logic_error("object dictionary: full");
  slots_[count_] = Slot{e, initial & mask_of(e), initial & mask_of(e)};
  return static_cast<int>(count_++);
}

int ObjectDictionary::find(std::uint16_t index, std::uint8_t subindex) const noexcept {
  for (std::size_t k = 0; k < count_; ++k)
    if (slots_[k].entry.index == index && slots_[k].entry.subindex == subindex)
      return static_cast<int>(k);
  return -1;
}

bool ObjectDictionary::has_index(std::uint16_t index) const noexcept {
  for (std::size_t k = 0; k < count_; ++k)
    if (slots_[k].entry.index == index) return true;
  return false;
}

void ObjectDictionary::reset(std::uint16_t from, std::uint16_t to) noexcept {
  for (std::size_t k = 0; k < count_; ++k)
    if (slots_[k].entry.index >= from && slots_[k].entry.index <= to)
      slots_[k].value = slots_[k].initial;
}

}  // namespace dualv::sim::canopen
