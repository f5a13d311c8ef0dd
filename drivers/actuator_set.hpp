#pragma once
// The n drives as one per-cycle interface, used by the control loop and the safety
// layer (ros2_control's read/write split). Implementations: the CANopen/CiA 402 drives
// on any CanBus (drivers/canopen_actuator_set.hpp) and the direct simulation
// (sim/sim_actuator_set.hpp). Drivers know nothing of the Dual-V: joint i is drive i.
//
// Call order per cycle: read() -> (estimate, control, safety) -> write().
// Both are noexcept, non-blocking and allocate nothing.
#include <array>
#include <cstdint>

namespace dualv::drivers {

inline constexpr int kMaxDrives = 8;

// What the layers above need to know of a drive's CiA 402 / NMT state.
enum class DriveState : std::uint8_t {
  kOffline = 0,  // no heartbeat / not booted / NMT not operational
  kDisabled,     // switch on disabled / ready to switch on / switched on: no torque
  kEnabled,      // operation enabled: follows the target torque
  kQuickStop,    // quick stop active (drive decelerates by itself)
  kFault,        // fault reaction active or fault
};

const char* to_string(DriveState s) noexcept;

struct DriveFeedback {
  DriveState state = DriveState::kOffline;
  double position = 0.0;         // joint angle [rad], encoder-quantised, zero as configured
  bool fresh = false;            // a new position arrived this cycle
  std::uint16_t statusword = 0;  // raw CiA 402 6041h, for telemetry
  std::uint16_t last_emcy = 0;   // last EMCY error code (0 = none or cleared)
  bool stop_input = false;       // hardwired e-stop circuit seen on a digital input (60FDh)
  double torque_actual = 0.0;    // [N m] when the drive reports it, else the last command
};

struct ActuatorFeedback {
  int n = 0;
  std::uint64_t cycle = 0;
  std::array<DriveFeedback, kMaxDrives> drive{};
};

// What every drive should do this cycle. Torques are only applied by drives in kEnabled.
enum class DriveRequest : std::uint8_t {
  kHold = 0,    // keep the current CiA 402 state
  kEnable,      // walk to Operation Enabled (target torque forced to 0 until there)
  kDisable,     // disable voltage / STO-like: torque off at once (CiA 402 transition 7/9/12)
  kQuickStop,   // the drive's own quick stop (605Ah)
  kFaultReset,  // rising edge of controlword bit 7
};

struct ActuatorCommand {
  int n = 0;
  std::array<double, kMaxDrives> torque{};  // [N m] target torque per drive
  DriveRequest request = DriveRequest::kHold;
};

enum class IoStatus : std::uint8_t {
  kOk = 0,
  kStale,     // some drive's feedback did not arrive this cycle (see DriveFeedback::fresh)
  kBusError,  // bus-off or a send failed; details in the implementation's counters
  kNotReady,  // not started / not booted
};

class ActuatorSet {
 public:
  virtual ~ActuatorSet() = default;
  virtual int size() const noexcept = 0;
  virtual IoStatus read(ActuatorFeedback& feedback) noexcept = 0;
  virtual IoStatus write(const ActuatorCommand& command) noexcept = 0;
};

}  // namespace dualv::drivers
