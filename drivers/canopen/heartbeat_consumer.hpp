#pragma once
// Heartbeat consumer for one node (CiA 301 7.2.8.3.2.2, the master's view of a drive's
// 1017h heartbeat): the node's NMT state and a timeout. Monitoring starts with the first
// heartbeat or with arm(); a node that never sends one is caught by the boot timeout
// (drivers/canopen/boot.hpp), not here. Timed out at exactly `timeout` after the last
// heartbeat (T - 1 ns: alive). Real-time safe.
#include <cstdint>

#include "firmware_if/nmt.hpp"

namespace dualv::drivers::canopen {

enum class HeartbeatEvent : std::uint8_t {
  kNone = 0,
  kBootUp,        // boot-up message (state 00h): the node (re)started, lost its configuration
  kStateChanged,  // a heartbeat with another NMT state than before
  kTimeout,       // reported once when the timeout expires
  kRecovered,     // a heartbeat after a timeout
};
const char* to_string(HeartbeatEvent e) noexcept;

class HeartbeatConsumer {
 public:
  HeartbeatConsumer() = default;
  HeartbeatConsumer(std::uint8_t node, std::uint64_t timeout_ns) noexcept
      : node_(node), timeout_ns_(timeout_ns) {}

  // Starts monitoring at `now` even without a heartbeat (after boot).
  void arm(std::uint64_t now_ns) noexcept;
  HeartbeatEvent on_heartbeat(fw::NmtState state, std::uint64_t now_ns) noexcept;
  // Call every cycle; kTimeout once when the silence reaches the timeout.
  HeartbeatEvent check(std::uint64_t now_ns) noexcept;

  std::uint8_t node() const noexcept { return node_; }
  bool seen() const noexcept { return seen_; }
  bool timed_out() const noexcept { return timed_out_; }
  // Last reported state; kBootUp until the first heartbeat.
  fw::NmtState state() const noexcept { return state_; }
  std::uint64_t last_ns() const noexcept { return last_ns_; }
  std::uint64_t timeouts() const noexcept { return timeouts_; }
  std::uint64_t boot_ups() const noexcept { return boot_ups_; }

 private:
  std::uint8_t node_ = 0;
  std::uint64_t timeout_ns_ = 0;
  std::uint64_t last_ns_ = 0;
  fw::NmtState state_ = fw::NmtState::kBootUp;
  bool armed_ = false;
  bool seen_ = false;
  bool timed_out_ = false;
  std::uint64_t timeouts_ = 0;
  std::uint64_t boot_ups_ = 0;
};

}  // namespace dualv::drivers::canopen
