#include "drivers/canopen/sync_producer.hpp"

#include "firmware_if/sync.hpp"

namespace dualv::drivers::canopen {

fw::Result<fw::CanFrame> SyncProducer::next_frame() const noexcept {
  return fw::encode_sync(fw::next_sync_counter(counter_, overflow_));
}

void SyncProducer::on_sent(BusStatus status) noexcept {
  if (status == BusStatus::kOk) {
    counter_ = fw::next_sync_counter(counter_, overflow_);
    ++sent_;
  } else {
    ++failed_;
  }
}

BusStatus SyncProducer::send(CanBus& bus) noexcept {
  const fw::Result<fw::CanFrame> f = next_frame();
  const BusStatus s = f ? bus.send(*f) : BusStatus::kIoError;
  on_sent(s);
  return s;
}

}  // namespace dualv::drivers::canopen
