#pragma once
// A CANopen slave's NMT state machine (CiA 301 7.3.2, figure 48) with its heartbeat
// producer (7.2.8.3.2.2, 1017h), like CANopenNode's CO_NMT: Initialisation -> boot-up
// message (700h + node, 00h) -> Pre-operational; start, stop, enter pre-operational from
// any state but Initialisation; reset node / reset communication go through Initialisation
// (the application resets its dictionary ranges, then calls boot_up()). What each state
// allows (table 75): SDO and EMCY in Pre-operational and Operational, PDOs in Operational
// only, heartbeat and NMT in all but Initialisation. The heartbeat (state byte 7Fh / 05h /
// 04h) is sent every 1017h ms from the boot-up or the last write of 1017h, 0 = off.
// noexcept, no allocation (tests/sim/canopen/nmt_slave_test.cpp).
#include <cstdint>
#include <limits>

#include "firmware_if/nmt.hpp"
#include "sim/canopen/frame_sink.hpp"
#include "sim/canopen/object_dictionary.hpp"

namespace dualv::sim::canopen {

enum class NmtSlaveState : std::uint8_t {
  kInitialisation,
  kPreOperational,
  kOperational,
  kStopped
};

// What an NMT command did.
struct NmtChange {
  NmtSlaveState from = NmtSlaveState::kInitialisation;
  NmtSlaveState to = NmtSlaveState::kInitialisation;
  bool reset_application = false;    // reset node: 0000h..FFFFh, then boot_up()
  bool reset_communication = false;  // reset communication: 1000h..1FFFh, then boot_up()
  bool left_operational() const noexcept {
    return from == NmtSlaveState::kOperational && to != NmtSlaveState::kOperational;
  }
};

class NmtSlave {
 public:
  static constexpr std::uint64_t kNever = std::numeric_limits<std::uint64_t>::max();

  // `producer_heartbeat_slot`: 1017h in the slave's dictionary.
  void attach(std::uint8_t node, int producer_heartbeat_slot) noexcept {
    node_ = node;
    slot_ = producer_heartbeat_slot;
  }
  NmtSlaveState state() const noexcept { return state_; }
  bool sdo_allowed() const noexcept {
    return state_ == NmtSlaveState::kPreOperational || state_ == NmtSlaveState::kOperational;
  }
  bool emcy_allowed() const noexcept { return sdo_allowed(); }
  bool pdo_allowed() const noexcept { return state_ == NmtSlaveState::kOperational; }

  // Initialisation done: the boot-up message, Pre-operational, the heartbeat timer starts.
  void boot_up(const ObjectDictionary& od, std::uint64_t now_ns, FrameSink& sink) noexcept;
  // Stays in (or goes back to) Initialisation, silent (a drive that does not boot).
  void hold_in_initialisation() noexcept { state_ = NmtSlaveState::kInitialisation; }
  // An NMT command addressed to this node (fw::addressed_to). Ignored in Initialisation.
  // For the two resets the state is Initialisation until the caller's boot_up().
  NmtChange on_command(fw::NmtCommand command) noexcept;

  // 1017h was written: the producer restarts from now.
  void producer_time_written(const ObjectDictionary& od, std::uint64_t now_ns) noexcept;
  // The heartbeat producer: true when a heartbeat was due (and given to `sink`).
  bool on_time(const ObjectDictionary& od, std::uint64_t now_ns, FrameSink& sink) noexcept;
  // When on_time has a heartbeat to send (kNever: producer off or Initialisation).
  std::uint64_t next_due_ns(const ObjectDictionary& od) const noexcept;

 private:
  std::uint64_t period_ns(const ObjectDictionary& od) const noexcept {
    return static_cast<std::uint64_t>(od.u(slot_)) * 1'000'000u;
  }

  std::uint8_t node_ = 1;
  int slot_ = -1;
  NmtSlaveState state_ = NmtSlaveState::kInitialisation;
  std::uint64_t next_hb_ns_ = 0;
};

}  // namespace dualv::sim::canopen
