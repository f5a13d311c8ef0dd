#include "drivers/canopen/sync_producer.hpp"

#include "firmware_if/sync.hpp"

namespace dualv::drivers::canopen {

BusStatus SyncProducer::send(CanBus& bus) noexcept {
  const std::uint8_t next = fw::next_sync_counter(counter_, overflow_);
  const fw::Result<fw::CanFrame> f = fw::encode_sync(next);
  if (!f) {
    ++failed_;
    return BusStatus::kIoError;
  }
  const BusStatus s = bus.send(*f);
  if (s == BusStatus::kOk) {
    counter_ = next;
    ++sent_;
  } else {
    ++failed_;
  }
  return s;
}

}  // namespace dualv::drivers::canopen
