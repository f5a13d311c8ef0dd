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

}  // namespace dualv::drivers
