#include "sim/canopen/heartbeat_consumer.hpp"

#include <algorithm>

#include "firmware_if/heartbeat.hpp"

namespace dualv::sim::canopen {

std::uint64_t HeartbeatConsumer::time_ns(const ObjectDictionary& od, std::size_t c) const noexcept {
  return static_cast<std::uint64_t>(fw::consumer_heartbeat_time_ms(od.u(slots_[c]))) * 1'000'000u;
}

unsigned HeartbeatConsumer::on_heartbeat(const ObjectDictionary& od, std::uint8_t node,
                                         std::uint64_t now) noexcept {
  unsigned back = 0;
  for (std::size_t c = 0; c < slots_.size(); ++c) {
    const std::uint32_t v = od.u(slots_[c]);
    if (fw::consumer_heartbeat_time_ms(v) == 0 || fw::consumer_heartbeat_node(v) != node) continue;
    last_ns_[c] = now;
    armed_[c] = true;  // monitoring starts with the first heartbeat
    if (lost_[c]) {
      lost_[c] = false;
      back |= 1u << c;
    }
  }
  return back;
}

unsigned HeartbeatConsumer::on_time(const ObjectDictionary& od, std::uint64_t now) noexcept {
  unsigned lost = 0;
  for (std::size_t c = 0; c < slots_.size(); ++c) {
    const std::uint64_t t = time_ns(od, c);
    if (t == 0 || !armed_[c] || lost_[c] || now - last_ns_[c] < t) continue;
    lost_[c] = true;
    lost |= 1u << c;
  }
  return lost;
}

bool HeartbeatConsumer::any_lost() const noexcept {
  return std::any_of(lost_.begin(), lost_.end(), [](bool l) { return l; });
}

std::uint64_t HeartbeatConsumer::next_due_ns(const ObjectDictionary& od) const noexcept {
  std::uint64_t due = kNever;
  for (std::size_t c = 0; c < slots_.size(); ++c) {
    const std::uint64_t t = time_ns(od, c);
    if (t != 0 && armed_[c] && !lost_[c]) due = std::min(due, last_ns_[c] + t);
  }
  return due;
}

}  // namespace dualv::sim::canopen
