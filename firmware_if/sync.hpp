#pragma once
// SYNC (CiA 301 7.2.5): COB-ID 080h (1005h), DLC 0, or DLC 1 with a counter 1..overflow
// when 1019h (synchronous counter overflow value) is 2..240.
#include <cstdint>

#include "firmware_if/can_frame.hpp"
#include "firmware_if/result.hpp"

namespace dualv::fw {

inline constexpr std::uint8_t kSyncCounterMin = 1;
inline constexpr std::uint8_t kSyncCounterOverflowMin = 2;
inline constexpr std::uint8_t kSyncCounterOverflowMax = 240;

struct Sync {
  std::uint8_t counter = 0;  // 0 = SYNC without counter (DLC 0)
  friend constexpr bool operator==(const Sync&, const Sync&) = default;
};

// counter 0 -> DLC 0; 1..240 -> DLC 1; > 240 -> kBadValue.
Result<CanFrame> encode_sync(std::uint8_t counter = 0) noexcept;
// kWrongFunction, kWrongDlc (> 1), kBadValue (counter 0 or > 240 in a DLC-1 frame).
Result<Sync> decode_sync(const CanFrame& frame) noexcept;

// The counter after `counter`: 1, 2, .., overflow, 1, ... (CiA 301 7.2.5.2.1.1). With
// overflow 0 (no counter) it stays 0. The host detects counter jumps by comparing.
constexpr std::uint8_t next_sync_counter(std::uint8_t counter, std::uint8_t overflow) noexcept {
  if (overflow < kSyncCounterOverflowMin) return 0;
  return (counter >= overflow || counter == 0) ? kSyncCounterMin
                                               : static_cast<std::uint8_t>(counter + 1);
}

}  // namespace dualv::fw
