#pragma once
// CANopen puts every multi-byte value on the wire little-endian (CiA 301 7.1.2).
// These helpers are the only place that byte order is spelled out.
#include <cstddef>
#include <cstdint>

namespace dualv::fw {

constexpr std::uint16_t get_u16_le(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
constexpr std::uint32_t get_u32_le(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}
// Reads n (0..4) bytes as an unsigned little-endian value.
constexpr std::uint32_t get_uint_le(const std::uint8_t* p, std::size_t n) noexcept {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < n && i < 4; ++i) v |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return v;
}
constexpr void put_u16_le(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v & 0xFFu);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
constexpr void put_u32_le(std::uint8_t* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>((v >> (8 * i)) & 0xFFu);
}
// Two's complement reinterpretation (well-defined since C++20).
constexpr std::int16_t as_i16(std::uint16_t v) noexcept { return static_cast<std::int16_t>(v); }
constexpr std::int32_t as_i32(std::uint32_t v) noexcept { return static_cast<std::int32_t>(v); }

}  // namespace dualv::fw
