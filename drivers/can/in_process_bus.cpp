#include "drivers/can/in_process_bus.hpp"

#include <stdexcept>
#include <string>

namespace dualv::drivers {

// ---------------------------------------------------------------------------------------
// InProcessBus (one endpoint)

InProcessBus::InProcessBus(InProcessHub& hub, std::size_t index, std::size_t capacity)
    : hub_(hub), index_(index), rx_(capacity) {}

BusStatus InProcessBus::send(const fw::CanFrame& frame) noexcept {
  if (bus_off_) {
    ++counters_.tx_dropped;
    return BusStatus::kBusOff;
  }
  if (!fw::is_valid(frame)) {
    // What a controller refuses (SocketCAN: EINVAL): a classic frame above 8 bytes, an FD
    // frame of a size no DLC code gives, an FD remote frame.
    ++counters_.tx_dropped;
    return BusStatus::kIoError;
  }
  if (fail_sends_ > 0) {
    // ENOBUFS: the controller's queue is full, the frame never left.
    --fail_sends_;
    ++counters_.tx_dropped;
    return BusStatus::kWouldBlock;
  }
  ++counters_.tx_frames;
  if (drop_ > 0) {
    // Lost on the wire: the sender cannot tell (as with a frame nobody acknowledged
    // that the controller gave up on, or a receiver that missed it).
    --drop_;
    ++hub_.stats_.dropped;
    return BusStatus::kOk;
  }
  fw::CanFrame copy = frame;
  if (corrupt_ > 0) {
    --corrupt_;
    for (std::size_t i = 0; i < copy.dlc && i < copy.data.size(); ++i) {
      copy.data[i] = static_cast<std::uint8_t>(copy.data[i] ^ corrupt_mask_);
    }
    ++hub_.stats_.corrupted;
  }
  std::size_t delay = 0;
  if (delay_ > 0) {
    --delay_;
    delay = delay_frames_;
  }
  hub_.transmit(index_, copy, delay);
  return BusStatus::kOk;
}

BusStatus InProcessBus::receive(fw::CanFrame& frame) noexcept {
  if (bus_off_) {
    return BusStatus::kBusOff;
  }
  if (rx_count_ == 0) {
    return BusStatus::kWouldBlock;
  }
  frame = rx_[rx_head_];
  rx_head_ = (rx_head_ + 1) % rx_.size();
  --rx_count_;
  ++counters_.rx_frames;
  return BusStatus::kOk;
}

BusStatus InProcessBus::state() const noexcept {
  if (bus_off_) {
    return BusStatus::kBusOff;
  }
  return error_passive_ ? BusStatus::kErrorPassive : BusStatus::kOk;
}

BusStatus InProcessBus::restart() noexcept {
  if (bus_off_ && refuse_restart_) {
    return BusStatus::kBusOff;
  }
  bus_off_ = false;
  error_passive_ = false;
  // Stale frames must never be processed after a restart: drop what we had received and
  // what we had sent that is still held back on the wire.
  rx_head_ = 0;
  rx_count_ = 0;
  hub_.discard_delayed_from(index_);
  ++counters_.restarts;
  return BusStatus::kOk;
}

void InProcessBus::force_bus_off(bool refuse_restart) noexcept {
  if (!bus_off_) {
    ++counters_.bus_off_events;
  }
  bus_off_ = true;
  refuse_restart_ = refuse_restart;
}

void InProcessBus::force_error_passive(bool on) noexcept {
  if (on && !error_passive_) {
    ++counters_.error_passive_events;
  }
  error_passive_ = on;
}

void InProcessBus::push(const fw::CanFrame& frame) noexcept {
  if (bus_off_) {
    return;  // a bus-off controller takes no part in bus traffic
  }
  if (rx_count_ == rx_.size()) {
    ++counters_.rx_overruns;  // the newest frame is lost, as in a socket receive buffer
    return;
  }
  rx_[(rx_head_ + rx_count_) % rx_.size()] = frame;
  ++rx_count_;
}

// ---------------------------------------------------------------------------------------
// InProcessHub

InProcessHub::InProcessHub(std::size_t endpoints, std::size_t queue_capacity,
                           std::size_t delay_capacity) {
  if (endpoints < 2) {
    throw std::invalid_argument("InProcessHub: a bus needs at least 2 endpoints, got " +
                                std::to_string(endpoints));
  }
  if (queue_capacity == 0 || delay_capacity == 0) {
    throw std::invalid_argument("InProcessHub: queue_capacity and delay_capacity must be > 0");
  }
  endpoints_.reserve(endpoints);
  for (std::size_t i = 0; i < endpoints; ++i) {
    // The constructor is private to the hub: endpoints exist only inside one.
    endpoints_.emplace_back(new InProcessBus(*this, i, queue_capacity));
  }
  delayed_.resize(delay_capacity);
}

InProcessHub::~InProcessHub() = default;

InProcessBus& InProcessHub::endpoint(std::size_t i) {
  if (i >= endpoints_.size()) {
    throw std::out_of_range("InProcessHub: endpoint " + std::to_string(i) + " of " +
                            std::to_string(endpoints_.size()));
  }
  return *endpoints_[i];
}

void InProcessHub::transmit(std::size_t from, const fw::CanFrame& frame,
                            std::size_t delay) noexcept {
  if (delay > 0) {
    if (delayed_count_ < delayed_.size()) {
      delayed_[delayed_count_++] = Delayed{frame, from, delay};
      ++stats_.delayed;
      return;
    }
    ++stats_.delay_overflows;
  }
  deliver(from, frame);
  // Each frame on the wire moves the held-back frames one step closer; those that reach
  // zero follow it, in the order they were sent. Released frames do not count as
  // "further frames" themselves, so k means k frames sent after the delayed one.
  std::size_t i = 0;
  while (i < delayed_count_) {
    if (--delayed_[i].remaining == 0) {
      const Delayed d = delayed_[i];
      remove_delayed(i);
      deliver(d.from, d.frame);
    } else {
      ++i;
    }
  }
}

void InProcessHub::deliver(std::size_t from, const fw::CanFrame& frame) noexcept {
  fw::CanFrame stamped = frame;
  stamped.timestamp_ns = now_ns_;
  ++stats_.delivered;
  for (auto& e : endpoints_) {
    if (e->index_ != from) {
      e->push(stamped);
    }
  }
}

void InProcessHub::release_delayed() noexcept {
  while (delayed_count_ > 0) {
    const Delayed d = delayed_[0];
    remove_delayed(0);
    deliver(d.from, d.frame);
  }
}

void InProcessHub::discard_delayed_from(std::size_t from) noexcept {
  std::size_t i = 0;
  while (i < delayed_count_) {
    if (delayed_[i].from == from) {
      remove_delayed(i);
      ++stats_.discarded_delayed;
    } else {
      ++i;
    }
  }
}

void InProcessHub::remove_delayed(std::size_t i) noexcept {
  // Keeps send order; the list is short (delay_capacity), so shifting is cheap.
  for (std::size_t j = i + 1; j < delayed_count_; ++j) {
    delayed_[j - 1] = delayed_[j];
  }
  --delayed_count_;
}

}  // namespace dualv::drivers
