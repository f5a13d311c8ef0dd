#pragma once
// A CanBus (drivers/can/can_bus.hpp) for the fuzz targets: keeps what is sent (the last
// kCapacity frames, with the send time), delivers nothing, and refuses sends on request.
#include <array>
#include <cstddef>
#include <cstdint>

#include "drivers/can/can_bus.hpp"

namespace dualv::fuzz {

class RecordingBus final : public drivers::CanBus {
 public:
  static constexpr std::size_t kCapacity = 256;
  struct Sent {
    fw::CanFrame frame;
    std::uint64_t time_ns = 0;
  };

  drivers::BusStatus send(const fw::CanFrame& frame) noexcept override {
    if (refuse_) {
      ++counters_.tx_dropped;
      return drivers::BusStatus::kWouldBlock;
    }
    sent_[count_ % kCapacity] = {frame, now_ns};
    ++count_;
    ++counters_.tx_frames;
    return drivers::BusStatus::kOk;
  }
  drivers::BusStatus receive(fw::CanFrame&) noexcept override {
    return drivers::BusStatus::kWouldBlock;
  }
  drivers::BusStatus state() const noexcept override { return drivers::BusStatus::kOk; }
  drivers::BusStatus restart() noexcept override { return drivers::BusStatus::kOk; }
  const drivers::BusCounters& counters() const noexcept override { return counters_; }

  void refuse_sends(bool on) noexcept { refuse_ = on; }
  std::size_t count() const noexcept { return count_; }  // frames sent so far
  // Frame number i (0 = first ever); only the last kCapacity are kept.
  const Sent& at(std::size_t i) const noexcept { return sent_[i % kCapacity]; }
  std::uint64_t now_ns = 0;  // stamped on each sent frame

 private:
  std::array<Sent, kCapacity> sent_{};
  std::size_t count_ = 0;
  bool refuse_ = false;
  drivers::BusCounters counters_{};
};

}  // namespace dualv::fuzz
