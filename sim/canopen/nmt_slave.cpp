#include "sim/canopen/nmt_slave.hpp"

#include "firmware_if/heartbeat.hpp"

namespace dualv::sim::canopen {

void NmtSlave::boot_up(const ObjectDictionary& od, std::uint64_t now, FrameSink& sink) noexcept {
  state_ = NmtSlaveState::kPreOperational;
  if (const fw::Result<fw::CanFrame> f = fw::encode_heartbeat(node_, fw::NmtState::kBootUp))
    sink.send(*f);
  next_hb_ns_ = now + period_ns(od);
}

NmtChange NmtSlave::on_command(fw::NmtCommand c) noexcept {
  NmtChange change;
  change.from = state_;
  if (state_ != NmtSlaveState::kInitialisation) {
    switch (c) {
      case fw::NmtCommand::kStart:
        state_ = NmtSlaveState::kOperational;
        break;
      case fw::NmtCommand::kStop:
        state_ = NmtSlaveState::kStopped;
        break;
      case fw::NmtCommand::kEnterPreOperational:
        state_ = NmtSlaveState::kPreOperational;
        break;
      case fw::NmtCommand::kResetNode:
        state_ = NmtSlaveState::kInitialisation;
        change.reset_application = true;
        break;
      case fw::NmtCommand::kResetCommunication:
        state_ = NmtSlaveState::kInitialisation;
        change.reset_communication = true;
        break;
    }
  }
  change.to = state_;
  return change;
}

void NmtSlave::producer_time_written(const ObjectDictionary& od, std::uint64_t now) noexcept {
  next_hb_ns_ = now + period_ns(od);
}

bool NmtSlave::on_time(const ObjectDictionary& od, std::uint64_t now, FrameSink& sink) noexcept {
  const std::uint64_t period = period_ns(od);
  if (state_ == NmtSlaveState::kInitialisation || period == 0 || now < next_hb_ns_) return false;
  fw::NmtState s = fw::NmtState::kPreOperational;
  if (state_ == NmtSlaveState::kOperational) s = fw::NmtState::kOperational;
  if (state_ == NmtSlaveState::kStopped) s = fw::NmtState::kStopped;
  if (const fw::Result<fw::CanFrame> f = fw::encode_heartbeat(node_, s)) sink.send(*f);
  next_hb_ns_ += period;
  if (next_hb_ns_ <= now) next_hb_ns_ = now + period;  // a late call does not burst
  return true;
}

std::uint64_t NmtSlave::next_due_ns(const ObjectDictionary& od) const noexcept {
  if (state_ == NmtSlaveState::kInitialisation || period_ns(od) == 0) return kNever;
  return next_hb_ns_;
}

}  // namespace dualv::sim::canopen
