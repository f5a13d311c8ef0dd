#include "sim/sim_actuator_set.hpp"

#include <algorithm>

#include "firmware_if/cia402.hpp"

namespace dualv::sim {

using drivers::DriveRequest;
using drivers::DriveState;
using drivers::IoStatus;

SimActuatorSet::SimActuatorSet(Plant& plant) noexcept
    : plant_(plant), n_(std::min(plant.size(), drivers::kMaxDrives)) {
  state_.fill(DriveState::kDisabled);
  emcy_.fill(0);
  torque_ = model::JointVector::Zero(plant.size());
}

std::uint16_t SimActuatorSet::statusword(int i) const noexcept {
  // The CiA 402 state a real drive would report for the simplified state (6041h); the
  // bit patterns come from firmware_if, the one place they are written.
  using fw::Cia402State;
  Cia402State s = Cia402State::kNotReadyToSwitchOn;
  switch (state_[i]) {
    case DriveState::kOffline:
      return 0;  // nothing received
    case DriveState::kDisabled:
      s = Cia402State::kSwitchOnDisabled;
      break;
    case DriveState::kEnabled:
      s = Cia402State::kOperationEnabled;
      break;
    case DriveState::kQuickStop:
      s = Cia402State::kQuickStopActive;
      break;
    case DriveState::kFault:
      s = Cia402State::kFault;
      break;
  }
  std::uint16_t w = static_cast<std::uint16_t>(fw::statusword_bits(s) | fw::sw::kRemote);
  if (state_[i] == DriveState::kEnabled)
    w = static_cast<std::uint16_t>(w | fw::sw::kVoltageEnabled | fw::sw::kDriveFollowsCommand);
  return w;
}

IoStatus SimActuatorSet::read(drivers::ActuatorFeedback& feedback) noexcept {
  const PlantOutput& out = plant_.output();
  feedback.n = n_;
  feedback.cycle = reads_++;
  bool all_fresh = true;
  for (int i = 0; i < n_; ++i) {
    drivers::DriveFeedback& d = feedback.drive[i];
    d.state = state_[i];
    d.fresh = state_[i] != DriveState::kOffline;
    all_fresh = all_fresh && d.fresh;
    if (d.fresh) d.position = out.q_measured[i];  // an offline drive's position is stale
    d.statusword = statusword(i);
    d.last_emcy = emcy_[i];
    d.stop_input = stop_input_;
    d.torque_actual = out.tau_applied[i];
  }
  return all_fresh ? IoStatus::kOk : IoStatus::kStale;
}

void SimActuatorSet::apply_request(int i, DriveRequest request, bool& torque_allowed) noexcept {
  DriveState& s = state_[i];
  torque_allowed = false;
  if (s == DriveState::kOffline) return;
  if (stop_input_ && s != DriveState::kFault) {
    s = DriveState::kDisabled;  // STO: the power stage is off whatever the host asks
    return;
  }
  switch (request) {
    case DriveRequest::kHold:
      break;
    case DriveRequest::kEnable:
      if (s == DriveState::kEnabled) {
        torque_allowed = true;
      } else if (s == DriveState::kDisabled) {
        s = DriveState::kEnabled;  // transitions 2-3-4; target torque 0 on this write
      } else if (s == DriveState::kQuickStop) {
        s = DriveState::kDisabled;  // transition 12 first, never 16
      }
      return;  // kFault stays kFault: it needs kFaultReset
    case DriveRequest::kDisable:
      if (s != DriveState::kFault) s = DriveState::kDisabled;
      return;
    case DriveRequest::kQuickStop:
      if (s == DriveState::kEnabled) s = DriveState::kQuickStop;
      return;
    case DriveRequest::kFaultReset:
      if (s == DriveState::kFault) {
        s = DriveState::kDisabled;  // transition 15
        emcy_[i] = 0;               // the drive's "error reset" EMCY clears the code
      }
      return;
  }
  torque_allowed = s == DriveState::kEnabled;
}

IoStatus SimActuatorSet::write(const drivers::ActuatorCommand& command) noexcept {
  torque_.setZero();
  if (command.n != n_) {
    ++rejected_writes_;
    plant_.command(torque_);  // torque off rather than a stale or misrouted command
    return IoStatus::kBusError;
  }
  bool all_online = true;
  for (int i = 0; i < n_; ++i) {
    bool allowed = false;
    apply_request(i, command.request, allowed);
    all_online = all_online && state_[i] != DriveState::kOffline;
    if (allowed) torque_[i] = command.torque[i];
  }
  // A non-finite torque makes the plant apply 0 N m on every joint (its kInvalidCommand),
  // as a drive decoding garbage would: reported here as a bus error.
  if (plant_.command(torque_) != PlantStatus::kOk) {
    ++rejected_writes_;
    return IoStatus::kBusError;
  }
  return all_online ? IoStatus::kOk : IoStatus::kStale;
}

void SimActuatorSet::inject_fault(int drive, std::uint16_t emcy_code) noexcept {
  if (drive < 0 || drive >= n_ || state_[drive] == DriveState::kOffline) return;
  state_[drive] = DriveState::kFault;
  emcy_[drive] = emcy_code;
  // A faulting drive removes its torque at once, not at the next write.
  torque_[drive] = 0.0;
  plant_.command(torque_);
}

void SimActuatorSet::set_offline(int drive, bool offline) noexcept {
  if (drive < 0 || drive >= n_) return;
  if (offline) {
    state_[drive] = DriveState::kOffline;
    torque_[drive] = 0.0;  // a drive that lost power or communication stops (6007h)
    plant_.command(torque_);
  } else if (state_[drive] == DriveState::kOffline)
    state_[drive] = DriveState::kDisabled;  // booted again: never straight back to enabled
}

void SimActuatorSet::set_stop_input(bool active) noexcept { stop_input_ = active; }

}  // namespace dualv::sim
