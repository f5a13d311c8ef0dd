#include "drivers/can/batching_bus.hpp"

#include <span>

namespace dualv::drivers {

BusStatus BatchingBus::send(const fw::CanFrame& frame) noexcept {
  if (inner_.state() == BusStatus::kBusOff) return BusStatus::kBusOff;
  if (tx_count_ == kCapacity) (void)flush();
  tx_[tx_count_++] = frame;
  return BusStatus::kOk;
}

BusStatus BatchingBus::receive(fw::CanFrame& frame) noexcept {
  if (rx_next_ == rx_count_) {
    // The last batch was short: the queue was empty then. Say so once without asking the
    // bus again (a caller reads until kWouldBlock: that would be one syscall per wake-up
    // for nothing); the call after that reads again.
    if (rx_short_) {
      rx_short_ = false;
      return BusStatus::kWouldBlock;
    }
    BusStatus s = BusStatus::kOk;
    rx_next_ = 0;
    rx_count_ = inner_.receive_many(rx_, s);
    rx_short_ = s == BusStatus::kWouldBlock;
    if (rx_count_ == 0) {
      rx_short_ = false;
      return s == BusStatus::kOk ? BusStatus::kWouldBlock : s;
    }
  }
  frame = rx_[rx_next_++];
  return BusStatus::kOk;
}

BusStatus BatchingBus::restart() noexcept {
  tx_count_ = 0;
  rx_next_ = rx_count_ = 0;
  rx_short_ = false;
  return inner_.restart();
}

BusStatus BatchingBus::flush() noexcept {
  BusStatus first = BusStatus::kOk;
  std::size_t k = 0;
  while (k < tx_count_) {
    BusStatus s = BusStatus::kOk;
    k += inner_.send_many(std::span(tx_).subspan(k, tx_count_ - k), s);
    if (k == tx_count_) break;
    if (first == BusStatus::kOk) first = s;
    if (s == BusStatus::kBusOff || s == BusStatus::kClosed) break;
    ++k;  // refused: dropped, the next is tried
  }
  tx_count_ = 0;
  return first;
}

}  // namespace dualv::drivers
