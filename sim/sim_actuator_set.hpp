#pragma once
// A drivers::ActuatorSet backed directly by a Plant, for the in-process closed loop
// (no CAN, no drive emulator). Joint i is drive i.
//
// Per cycle the loop calls read() -> (estimate, control, safety) -> write(), then advances
// the plant itself (plant.advance(period)): stepping is kept out of write() so the loop,
// not this class, decides the timing, deterministically.
//
// Drive states, simplified from CiA 402 (firmware_if/cia402.hpp) to what the layers above
// see (drivers::DriveState):
//   kDisabled  at start. kEnable -> kEnabled; the enabling write applies 0 N m (target
//              torque forced to 0 until Operation Enabled: no jump on enable).
//   kEnabled   follows the target torque.
//   kDisable   from any state but kFault/kOffline -> kDisabled, torque off at once.
//   kQuickStop from kEnabled -> kQuickStop, torque off at once (the drive's own quick-stop
//              deceleration ramp is not modelled). kEnable from kQuickStop goes back
//              through kDisabled first (transition 12, then 2-3-4 on the next kEnable),
//              as firmware_if's next_transition() does: never transition 16.
//   kFault     injected by tests (inject_fault): torque off; kFaultReset -> kDisabled.
//   kOffline   injected by tests (set_offline): torque off, no fresh position; coming back
//              online lands in kDisabled.
// The hardwired stop input (set_stop_input) acts like STO: torque off, kDisabled, and the
// flag is reported in every drive's feedback.
// Everything is noexcept and allocation-free after construction.
#include <array>
#include <cstdint>

#include "drivers/actuator_set.hpp"
#include "sim/plant.hpp"

namespace dualv::sim {

class SimActuatorSet final : public drivers::ActuatorSet {
 public:
  explicit SimActuatorSet(Plant& plant) noexcept;

  int size() const noexcept override { return n_; }
  // Encoder-quantised positions from the plant (fresh every cycle unless offline), the
  // drive states and the applied torques. kStale when some drive is offline.
  drivers::IoStatus read(drivers::ActuatorFeedback& feedback) noexcept override;
  // Applies the request to every drive, then hands the torques of enabled drives (0 N m for
  // all others) to the plant. kBusError when command.n does not match (nothing applied but
  // torque off), kStale when some drive is offline.
  drivers::IoStatus write(const drivers::ActuatorCommand& command) noexcept override;

  // Test hooks (failure injection).
  void inject_fault(int drive, std::uint16_t emcy_code) noexcept;
  void set_offline(int drive, bool offline) noexcept;
  void set_stop_input(bool active) noexcept;

  drivers::DriveState state(int drive) const noexcept { return state_[drive]; }
  Plant& plant() noexcept { return plant_; }
  std::uint64_t rejected_writes() const noexcept { return rejected_writes_; }

 private:
  void apply_request(int i, drivers::DriveRequest request, bool& torque_allowed) noexcept;
  std::uint16_t statusword(int i) const noexcept;

  Plant& plant_;
  int n_ = 0;
  std::array<drivers::DriveState, drivers::kMaxDrives> state_{};
  std::array<std::uint16_t, drivers::kMaxDrives> emcy_{};
  bool stop_input_ = false;
  std::uint64_t reads_ = 0;
  std::uint64_t rejected_writes_ = 0;
  model::JointVector torque_;  // what goes to the plant this cycle [N m]
};

}  // namespace dualv::sim
