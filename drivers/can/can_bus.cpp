#include "drivers/can/can_bus.hpp"

namespace dualv::drivers {

const char* to_string(BusStatus s) noexcept {
  switch (s) {
    case BusStatus::kOk:
      return "ok";
    case BusStatus::kWouldBlock:
      return "would block";
    case BusStatus::kBusOff:
      return "bus-off";
    case BusStatus::kErrorPassive:
      return "error passive";
    case BusStatus::kIoError:
      return "I/O error";
    case BusStatus::kClosed:
      return "closed";
  }
  return "unknown";
}

std::size_t CanBus::send_many(std::span<const fw::CanFrame> frames, BusStatus& status) noexcept {
  status = BusStatus::kOk;
  std::size_t sent = 0;
  for (const fw::CanFrame& f : frames) {
    status = send(f);
    if (status != BusStatus::kOk) break;
    ++sent;
  }
  return sent;
}

std::size_t CanBus::receive_many(std::span<fw::CanFrame> frames, BusStatus& status) noexcept {
  status = BusStatus::kOk;
  std::size_t got = 0;
  while (got < frames.size()) {
    status = receive(frames[got]);
    if (status != BusStatus::kOk) break;
    ++got;
  }
  return got;
}

}  // namespace dualv::drivers
