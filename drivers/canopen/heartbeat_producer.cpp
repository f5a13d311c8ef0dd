#include "drivers/canopen/heartbeat_producer.hpp"

#include "drivers/canopen/clock.hpp"
#include "firmware_if/heartbeat.hpp"

namespace dualv::drivers::canopen {

bool HeartbeatProducer::due(std::uint64_t now_ns) const noexcept {
  return !started_ || expired(last_ns_, now_ns, period_ns_);
}

void HeartbeatProducer::on_sent(BusStatus status, std::uint64_t now_ns) noexcept {
  if (status != BusStatus::kOk) {
    ++failed_;
    return;
  }
  // Keep the schedule (period multiples from the first beat) unless we fell behind.
  last_ns_ = (started_ && now_ns - last_ns_ < 2 * period_ns_) ? last_ns_ + period_ns_ : now_ns;
  started_ = true;
  ++sent_;
}

BusStatus HeartbeatProducer::poll(CanBus& bus, std::uint64_t now_ns, fw::NmtState state) noexcept {
  if (!due(now_ns)) return BusStatus::kOk;
  const fw::Result<fw::CanFrame> f = fw::encode_heartbeat(node_, state);
  const BusStatus s = f ? bus.send(*f) : BusStatus::kIoError;
  on_sent(s, now_ns);
  return s;
}

}  // namespace dualv::drivers::canopen
