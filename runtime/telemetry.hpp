#pragma once
// Plain telemetry samples: what the real-time cycle hands to the publisher
// thread. Fixed-size, trivially copyable, no LCM types and no std::string, so
// queueing one is a memcpy into a preallocated slot (docs/architecture.md: nothing in the
// cycle allocates). The publisher converts them to dualv_lcm messages.
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <type_traits>

#include "control/loop/cycle_stats.hpp"

namespace dualv::runtime {

// Largest number of actuated joints a sample carries (the Dual-V has 4).
inline constexpr int kMaxJoints = 8;

// Copies text into a fixed buffer, truncating, always NUL-terminated. noexcept
// and allocation-free: usable in the cycle.
template <std::size_t N>
void copy_text(char (&dst)[N], std::string_view src) noexcept {
  const std::size_t n = std::min(src.size(), N - 1);
  std::memcpy(dst, src.data(), n);
  dst[n] = '\0';
}

// Mirrors dualv_lcm::robot_state_t (see lcm/robot_state_t.lcm for units).
struct StateSample {
  std::int64_t utime = 0;  // 0: the publisher stamps it with its own wall clock
  std::int64_t cycle = 0;
  double t = 0.0;
  std::int16_t n = 0;
  std::array<double, kMaxJoints> q{};
  std::array<double, kMaxJoints> q_dot{};
  std::array<double, kMaxJoints> tau_cmd{};
  std::array<double, kMaxJoints> tau_internal{};
  std::array<double, 3> X{};
  std::array<double, 3> X_d{};
  std::array<double, 3> tracking_error{};
  double lambda = 0.0;
  std::int32_t segment = -1;
  std::int8_t safety_state = 0;  // dualv_lcm::robot_state_t::SAFETY_*
  char safety_text[24] = {};
  std::int32_t status_flags = 0;  // dualv_lcm::robot_state_t::FLAG_*
  std::array<double, 3> stream_target{};
  double stream_age = -1.0;
  std::int64_t stream_accepted = 0;
  std::int64_t stream_refused = 0;
};

// Mirrors dualv_lcm::fault_event_t.
struct FaultSample {
  std::int64_t utime = 0;
  std::int64_t cycle = 0;
  char cause[64] = {};
  char reaction[16] = {};
  std::int16_t node = -1;
  std::int32_t detection_latency_cycles = 0;
  std::int16_t n = 0;
  std::array<double, kMaxJoints> tau_at_detection{};
  char text[128] = {};
};

// Mirrors dualv_lcm::loop_stats_t.
struct LoopStatsSample {
  std::int64_t utime = 0;
  control::LoopStatsSummary stats;
  std::int64_t telemetry_dropped = 0;
  bool realtime = false;
};

static_assert(std::is_trivially_copyable_v<StateSample>);
static_assert(std::is_trivially_copyable_v<FaultSample>);
static_assert(std::is_trivially_copyable_v<LoopStatsSample>);

}  // namespace dualv::runtime
