#include "drivers/actuator_set.hpp"

namespace dualv::drivers {

const char* to_string(DriveState s) noexcept {
  switch (s) {
    case DriveState::kOffline:
      return "offline";
    case DriveState::kDisabled:
      return "disabled";
    case DriveState::kEnabled:
      return "enabled";
    case DriveState::kQuickStop:
      return "quick stop";
    case DriveState::kFault:
      return "fault";
  }
  return "unknown";
}

}  // namespace dualv::drivers
