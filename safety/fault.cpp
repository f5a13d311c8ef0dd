#include "safety/fault.hpp"

namespace dualv::safety {

const char* to_string(Reaction r) noexcept {
  switch (r) {
    case Reaction::kWarn:
      return "warning";
    case Reaction::kSs1:
      return "SS1";
    case Reaction::kSto:
      return "STO";
  }
  return "unknown";
}

const char* to_string(Fault f) noexcept {
  switch (f) {
    case Fault::kEstopLcm:
      return "e-stop (LCM)";
    case Fault::kEstopSignal:
      return "e-stop (signal)";
    case Fault::kEstopCli:
      return "e-stop (console)";
    case Fault::kEstopInput:
      return "e-stop circuit (drive input)";
    case Fault::kDriveLost:
      return "drive lost";
    case Fault::kDriveFault:
      return "drive fault";
    case Fault::kBusError:
      return "bus error";
    case Fault::kStaleFeedback:
      return "stale feedback";
    case Fault::kEncoderJump:
      return "encoder jump";
    case Fault::kInvalidState:
      return "invalid state";
    case Fault::kDeadlineMiss:
      return "deadline miss";
    case Fault::kDeadlineMisses:
      return "consecutive deadline misses";
    case Fault::kSafetyCheckMissed:
      return "safety check missed";
    case Fault::kNonFiniteCommand:
      return "non-finite command";
    case Fault::kTorqueLimit:
      return "torque limit";
    case Fault::kTorqueRate:
      return "torque rate limit";
    case Fault::kJointVelocity:
      return "joint velocity";
    case Fault::kPlateVelocity:
      return "plate velocity";
    case Fault::kWorkspace:
      return "workspace";
    case Fault::kSingularity:
      return "singularity";
    case Fault::kTrackingError:
      return "tracking error";
    case Fault::kCommandStreamStale:
      return "command stream stale";
    case Fault::kStopTimeout:
      return "SS1 stop timeout";
    case Fault::kCount:
      break;
  }
  return "none";
}

}  // namespace dualv::safety
