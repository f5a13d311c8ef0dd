#pragma once
// A CANopen slave's heartbeat consumer (CiA 301 7.2.8.3.2.2, 1016h sub1..n = producer node
// << 16 | time in ms, 0 ms = entry unused), like CANopenNode's CO_HBconsumer: monitoring of
// an entry starts with the first heartbeat received from its node; a silence of at least
// the consumer time is a heartbeat event (reported once), and the heartbeat coming back
// ends it. Writing 1016h restarts monitoring (reset()). Entries are reported as bit masks
// (bit c = sub-index c + 1). noexcept, no allocation
// (tests/sim/canopen/heartbeat_consumer_test.cpp).
#include <array>
#include <cstdint>
#include <limits>

#include "sim/canopen/object_dictionary.hpp"

namespace dualv::sim::canopen {

inline constexpr int kHeartbeatConsumers = 2;  // 1016h sub1..2

class HeartbeatConsumer {
 public:
  static constexpr std::uint64_t kNever = std::numeric_limits<std::uint64_t>::max();

  // The dictionary slots of 1016h sub1..kHeartbeatConsumers.
  void attach(const std::array<int, kHeartbeatConsumers>& slots) noexcept { slots_ = slots; }
  // A heartbeat (or boot-up) of `node`: the entries that were lost and are back.
  unsigned on_heartbeat(const ObjectDictionary& od, std::uint8_t node,
                        std::uint64_t now_ns) noexcept;
  // The entries whose consumer time has run out since their last heartbeat (each once).
  unsigned on_time(const ObjectDictionary& od, std::uint64_t now_ns) noexcept;
  // Monitoring stopped until each node's next heartbeat (1016h written, reset communication).
  void reset() noexcept {
    armed_.fill(false);
    lost_.fill(false);
  }
  bool lost(int c) const noexcept { return lost_[static_cast<std::size_t>(c)]; }
  bool any_lost() const noexcept;
  // When on_time may report the next loss (kNever: none monitored).
  std::uint64_t next_due_ns(const ObjectDictionary& od) const noexcept;

 private:
  std::uint64_t time_ns(const ObjectDictionary& od, std::size_t c) const noexcept;

  std::array<int, kHeartbeatConsumers> slots_{-1, -1};
  std::array<std::uint64_t, kHeartbeatConsumers> last_ns_{};
  std::array<bool, kHeartbeatConsumers> armed_{};
  std::array<bool, kHeartbeatConsumers> lost_{};
};

}  // namespace dualv::sim::canopen
