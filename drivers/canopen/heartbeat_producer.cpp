#include "drivers/canopen/heartbeat_producer.hpp"

#include "drivers/canopen/clock.hpp"
#include "firmware_if/heartbeat.hpp"

namespace dualv::drivers::canopen {

BusStatus HeartbeatProducer::poll(CanBus& bus, std::uint64_t now_ns, fw::NmtState state) noexcept {
  if (started_ && !expired(last_ns_, now_ns, period_ns_)) return BusStatus::kOk;
  const fw::Result<fw::CanFrame> f = fw::encode_heartbeat(node_, state);
  if (!f) {
    ++failed_;
    return BusStatus::kIoError;
  }
  const BusStatus s = bus.send(*f);
  if (s != BusStatus::kOk) {
    ++failed_;
    return s;
  }
  // Keep the schedule (period multiples from the first beat) unless we fell behind.
  last_ns_ = (started_ && now_ns - last_ns_ < 2 * period_ns_) ? last_ns_ + period_ns_ : now_ns;
  started_ = true;
  ++sent_;
  return s;
}

}  // namespace dualv::drivers::canopen
