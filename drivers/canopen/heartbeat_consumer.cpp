#include "drivers/canopen/heartbeat_consumer.hpp"

#include "drivers/canopen/clock.hpp"

namespace dualv::drivers::canopen {

const char* to_string(HeartbeatEvent e) noexcept {
  switch (e) {
    case HeartbeatEvent::kNone:
      return "none";
    case HeartbeatEvent::kBootUp:
      return "boot-up";
    case HeartbeatEvent::kStateChanged:
      return "NMT state changed";
    case HeartbeatEvent::kTimeout:
      return "heartbeat timeout";
    case HeartbeatEvent::kRecovered:
      return "heartbeat recovered";
  }
  return "?";
}

void HeartbeatConsumer::arm(std::uint64_t now_ns) noexcept {
  armed_ = true;
  last_ns_ = now_ns;
  timed_out_ = false;
}

HeartbeatEvent HeartbeatConsumer::on_heartbeat(fw::NmtState state, std::uint64_t now_ns) noexcept {
  const bool was_timed_out = timed_out_;
  const bool changed = !seen_ || state != state_;
  last_ns_ = now_ns;
  armed_ = true;
  seen_ = true;
  timed_out_ = false;
  state_ = state;
  if (state == fw::NmtState::kBootUp) {
    ++boot_ups_;
    return HeartbeatEvent::kBootUp;
  }
  if (was_timed_out) return HeartbeatEvent::kRecovered;
  return changed ? HeartbeatEvent::kStateChanged : HeartbeatEvent::kNone;
}

HeartbeatEvent HeartbeatConsumer::check(std::uint64_t now_ns) noexcept {
  if (!armed_ || timed_out_ || timeout_ns_ == 0) return HeartbeatEvent::kNone;
  if (!expired(last_ns_, now_ns, timeout_ns_)) return HeartbeatEvent::kNone;
  timed_out_ = true;
  ++timeouts_;
  return HeartbeatEvent::kTimeout;
}

}  // namespace dualv::drivers::canopen
