#include "sim/canopen/object_dictionary.hpp"

#include <algorithm>
#include <stdexcept>

namespace dualv::sim::canopen {

int ObjectDictionary::add(const fw::OdEntry& e, std::uint32_t initial) {
  if (std::find(absent_.begin(), absent_.end(), e.index) != absent_.end()) return -1;
  if (find(e) >= 0) throw std::logic_error("object dictionary: entry added twice");
  if (count_ >= slots_.size()) throw std::logic_error("object dictionary: full");
  slots_[count_] = Slot{e, initial & mask_of(e), initial & mask_of(e)};
  const std::uint32_t key = key_of(e.index, e.subindex) | static_cast<std::uint32_t>(count_);
  const auto end = sorted_.begin() + static_cast<std::ptrdiff_t>(count_);
  const auto at = std::upper_bound(sorted_.begin(), end, key);
  std::copy_backward(at, end, end + 1);
  *at = key;
  return static_cast<int>(count_++);
}

int ObjectDictionary::find(std::uint16_t index, std::uint8_t subindex) const noexcept {
  const std::uint32_t key = key_of(index, subindex);
  const auto end = sorted_.begin() + static_cast<std::ptrdiff_t>(count_);
  const auto it = std::lower_bound(sorted_.begin(), end, key);
  if (it == end || (*it & ~0xFFu) != key) return -1;
  return static_cast<int>(*it & 0xFFu);
}

bool ObjectDictionary::has_index(std::uint16_t index) const noexcept {
  const std::uint32_t key = key_of(index, 0);
  const auto end = sorted_.begin() + static_cast<std::ptrdiff_t>(count_);
  const auto it = std::lower_bound(sorted_.begin(), end, key);
  return it != end && (*it >> 16) == index;
}

void ObjectDictionary::reset(std::uint16_t from, std::uint16_t to) noexcept {
  for (std::size_t k = 0; k < count_; ++k)
    if (slots_[k].entry.index >= from && slots_[k].entry.index <= to)
      slots_[k].value = slots_[k].initial;
}

}  // namespace dualv::sim::canopen
