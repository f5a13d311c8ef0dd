#pragma once
// Unit scaling between the wire (CiA 402 integers) and SI (rad, N m).
//  - Position 6064h: encoder counts; counts per revolution from 608Fh (increments per motor
//    revolution; direct drive, so motor revolution = joint revolution).
//  - Torque 6071h/6077h: per mille of the motor rated torque 6076h (CiA 402-2), 6076h in mN m.
// Conversions to integers round half away from zero and saturate to the integer type;
// NaN and a non-positive scale give 0 (no torque, no motion). All constexpr and noexcept.
#include <cstdint>
#include <limits>

namespace dualv::fw {

inline constexpr double kTwoPi = 6.283185307179586476925286766559;

namespace detail {
// Round half away from zero, then clamp to [lo, hi]; NaN -> 0.
constexpr std::int64_t round_saturate(double x, std::int64_t lo, std::int64_t hi) noexcept {
  if (!(x == x)) return 0;  // NaN
  if (x <= static_cast<double>(lo)) return lo;
  if (x >= static_cast<double>(hi)) return hi;
  return static_cast<std::int64_t>(x >= 0.0 ? x + 0.5 : x - 0.5);  // truncation toward 0
}
}  // namespace detail

// counts -> rad; counts_per_rev 0 -> 0.
constexpr double counts_to_rad(std::int32_t counts, std::uint32_t counts_per_rev) noexcept {
  return counts_per_rev == 0 ? 0.0 : static_cast<double>(counts) * kTwoPi / counts_per_rev;
}
// rad -> counts, rounded half away from zero, saturated to i32.
constexpr std::int32_t rad_to_counts(double rad, std::uint32_t counts_per_rev) noexcept {
  if (counts_per_rev == 0) return 0;
  return static_cast<std::int32_t>(detail::round_saturate(
      rad * counts_per_rev / kTwoPi, std::numeric_limits<std::int32_t>::min(),
      std::numeric_limits<std::int32_t>::max()));
}
// 608Fh gives increments per motor revolutions; counts per revolution = sub1 / sub2
// (integer: the drives here have sub2 = 1). 0 when sub2 is 0.
constexpr std::uint32_t counts_per_rev(std::uint32_t increments,
                                       std::uint32_t motor_revs) noexcept {
  return motor_revs == 0 ? 0 : increments / motor_revs;
}

// 6076h (mN m) -> N m.
constexpr double rated_torque_nm(std::uint32_t rated_milli_nm) noexcept {
  return static_cast<double>(rated_milli_nm) / 1000.0;
}
// Per mille of rated torque -> N m.
constexpr double per_mille_to_nm(std::int16_t per_mille, double rated_nm) noexcept {
  return static_cast<double>(per_mille) * rated_nm / 1000.0;
}
// N m -> per mille (target torque 6071h), rounded half away from zero, saturated to
// [-32768, 32767]. The safety layer limits torque far below that: saturation here only
// keeps a wild value from wrapping around and changing sign.
constexpr std::int16_t nm_to_per_mille(double nm, double rated_nm) noexcept {
  if (!(rated_nm > 0.0)) return 0;
  return static_cast<std::int16_t>(
      detail::round_saturate(nm * 1000.0 / rated_nm, std::numeric_limits<std::int16_t>::min(),
                             std::numeric_limits<std::int16_t>::max()));
}
// N m -> max torque 6072h (u16 per mille), rounded, saturated to [0, 65535].
constexpr std::uint16_t max_torque_per_mille(double nm, double rated_nm) noexcept {
  if (!(rated_nm > 0.0)) return 0;
  return static_cast<std::uint16_t>(
      detail::round_saturate(nm * 1000.0 / rated_nm, 0, std::numeric_limits<std::uint16_t>::max()));
}

}  // namespace dualv::fw
