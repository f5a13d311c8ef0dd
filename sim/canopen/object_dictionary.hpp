#pragma once
// A CANopen slave's object dictionary (CiA 301 7.4): the entries of firmware_if with their
// values and power-on defaults, in a fixed table built at set-up (no allocation after it),
// like CANopenNode's CO_ODinterface. The drive emulator (sim/drive_emulator.cpp) and its
// SDO server (sim/canopen/sdo_server.hpp) see the drive through it.
//
// Slots: add() returns the entry's slot, found again by find(); -1 means "not in this
// dictionary" (never added, or left out as an object the drive does not have), and every
// accessor treats -1 as absent (value 0, writes ignored). Values are kept as the raw bit
// pattern in the entry's size (i16 -1 is FFFFh).
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "firmware_if/object_dictionary.hpp"

namespace dualv::sim::canopen {

inline constexpr std::size_t kDictionaryCapacity = 192;

// The bits of the entry's size (all 32 for 4 bytes).
constexpr std::uint32_t mask_of(const fw::OdEntry& e) noexcept {
  return e.size() >= 4 ? 0xFFFFFFFFu : ((1u << e.bits()) - 1u);
}
// `raw` in `size` bytes read as signed.
constexpr std::int32_t as_signed(std::uint32_t raw, std::uint8_t size) noexcept {
  switch (size) {
    case 1:
      return static_cast<std::int8_t>(raw & 0xFFu);
    case 2:
      return static_cast<std::int16_t>(raw & 0xFFFFu);
    default:
      return static_cast<std::int32_t>(raw);
  }
}

class ObjectDictionary {
 public:
  // Set-up: objects (indices) this drive does not have; add() skips them.
  void set_absent(std::vector<std::uint16_t> indices) { absent_ = std::move(indices); }
  // Set-up: a new entry with its power-on value; its slot, or -1 when the index is absent.
  // Throws std::logic_error when the table is full or the entry exists already.
  int add(const fw::OdEntry& entry, std::uint32_t initial);

  int find(std::uint16_t index, std::uint8_t subindex) const noexcept;
  int find(const fw::OdEntry& e) const noexcept { return find(e.index, e.subindex); }
  bool has_index(std::uint16_t index) const noexcept;
  const fw::OdEntry& entry(int slot) const noexcept {
    return slots_[static_cast<std::size_t>(slot)].entry;
  }
  std::uint32_t u(int slot) const noexcept {
    return slot >= 0 ? slots_[static_cast<std::size_t>(slot)].value : 0;
  }
  std::int32_t i(int slot) const noexcept {
    return slot >= 0 ? as_signed(u(slot), entry(slot).size()) : 0;
  }
  void set(int slot, std::uint32_t value) noexcept {
    if (slot >= 0) slots_[static_cast<std::size_t>(slot)].value = value & mask_of(entry(slot));
  }
  // Every entry with index in [from, to] back to its power-on value (NMT reset node:
  // 0000h..FFFFh; reset communication: 1000h..1FFFh, CiA 301 7.2.8.2.2).
  void reset(std::uint16_t from, std::uint16_t to) noexcept;
  std::size_t size() const noexcept { return count_; }

 private:
  struct Slot {
    fw::OdEntry entry{};
    std::uint32_t value = 0;
    std::uint32_t initial = 0;
  };
  // (index << 8 | subindex) << 8 | slot of every entry, ascending: find() and has_index()
  // search it in log2(capacity) steps instead of scanning the slots (the emulator looks
  // entries up for every SDO request and every PDO record rebuild).
  static_assert(kDictionaryCapacity <= 256, "a slot must fit in the key's low byte");
  static constexpr std::uint32_t key_of(std::uint16_t index, std::uint8_t subindex) noexcept {
    return (static_cast<std::uint32_t>(index) << 16) | (static_cast<std::uint32_t>(subindex) << 8);
  }
  std::array<Slot, kDictionaryCapacity> slots_{};
  std::array<std::uint32_t, kDictionaryCapacity> sorted_{};
  std::size_t count_ = 0;
  std::vector<std::uint16_t> absent_;
};

}  // namespace dualv::sim::canopen
