#pragma once
// The n CiA 402 drives on a CanBus as one ActuatorSet (drivers/actuator_set.hpp), the
// same whether the bus is a real controller, vcan, or the in-process bus.
//
// Cycle order (one SYNC per control cycle; docs/architecture.md "CAN contract"):
//
//   cycle k:   read()  drains every frame received since the last read(): the TPDO1s the
//                      drives sent after SYNC k-1 (statusword, position), heartbeats, EMCYs.
//              ... estimator, controller, safety ...
//              write() per drive the CiA 402 controlword (Cia402Drive) and target torque
//                      (0 unless Operation enabled), as RPDOs (per-drive: 200h+id with
//                      controlword + torque; broadcast: 200h with every torque, plus the
//                      controlword RPDO 200h+id when it changes or every
//                      can.controlword_refresh; fd: one CAN FD frame on 200h with every
//                      controlword + torque), THEN the SYNC (080h), then the master's
//                      heartbeat when due.
//   drives:            apply the RPDO data at SYNC k, sample, answer TPDO1 (transmission
//                      type 1; fd: as an FD frame); broadcast: TPDO1 = position only, and
//                      TPDO3 = statusword
//                      when it changed (at most once per can.statusword_inhibit, at least
//                      once per can.statusword_refresh).
//   cycle k+1: read()  gets them.
//
// Broadcast layout bounds (issue 15): a drive's state change reaches read() at most
// statusword_inhibit + 1 cycle after the drive's SYNC sample; a controlword change goes on
// the wire at most controlword_inhibit after write() asked for it. A drive whose statusword
// has not come for ceil(statusword_refresh / period) + can.timeouts.stale_cycles cycles is
// not fresh (its feedback is stale, health STALE), as a missing position TPDO1 is.
//
// So feedback is one cycle old by construction, and a target torque sent at k acts from
// SYNC k. The drives are booted before this class runs (drivers/canopen/boot.hpp,
// drivers/canopen_setup.hpp); it never sends SDO or NMT.
//
// Faults (docs/architecture.md "Safety"): bus-off is latched (read/write return kBusError and send
// nothing; recover_bus() restarts the controller, after which every drive is disabled and
// needs a new kEnable); a send refused with ENOBUFS is counted and dropped, never queued
// (nothing is sent late); duplicate, late and out-of-order TPDOs, foreign SYNCs and SYNC
// counter jumps are counted; a drive whose heartbeat times out, which boots again, or whose
// NMT state leaves Operational is lost (DriveState::kOffline, torque 0, needs kEnable).
//
// Hooks for the safety layer: events() lists what happened in the last read()/write() as
// bit masks per drive (EMCY raised, heartbeat lost, own stop, ...), health() gives each
// drive's OK/WARN/ERROR/STALE with the reason, last_sent() is what actually went on the
// wire (per mille and controlword), counters() and drive_counters() count everything.
//
// Real-time: read/write/health/events/recover_bus are noexcept and allocate nothing. The
// constructor and prime()/service() are set-up code.
#include <array>
#include <cstdint>
#include <functional>
#include <string>

#include "drivers/actuator_set.hpp"
#include "drivers/can/can_bus.hpp"
#include "drivers/canopen/clock.hpp"
#include "drivers/canopen/emcy_consumer.hpp"
#include "drivers/canopen/heartbeat_consumer.hpp"
#include "drivers/canopen/heartbeat_producer.hpp"
#include "drivers/canopen/sync_producer.hpp"
#include "drivers/canopen/waiter.hpp"
#include "drivers/canopen_config.hpp"
#include "drivers/cia402_drive.hpp"
#include "firmware_if/bus_layout.hpp"
#include "firmware_if/nmt.hpp"

namespace dualv::drivers {

enum class DriveHealth : std::uint8_t { kOk = 0, kWarn, kError, kStale };
const char* to_string(DriveHealth h) noexcept;

// One drive's health, for `dualv status`, telemetry and the safety layer.
struct DriveHealthReport {
  std::uint8_t node = 0;
  DriveHealth health = DriveHealth::kStale;
  const char* reason = "no data yet";  // static text
  bool nmt_known = false;              // a heartbeat was seen
  fw::NmtState nmt_state = fw::NmtState::kBootUp;
  bool heartbeat_timed_out = false;
  bool cia402_known = false;
  fw::Cia402State cia402_state = fw::Cia402State::kNotReadyToSwitchOn;
  DriveState state = DriveState::kOffline;
  bool emcy_active = false;
  std::uint16_t last_emcy_code = 0;  // last raised (kept after a reset)
  const char* last_emcy_text = "none";
  StopCause own_stop = StopCause::kNone;
  bool transition_timed_out = false;
  bool stop_input = false;           // e-stop circuit open (60FDh via TPDO2)
  std::uint32_t digital_inputs = 0;  // last 60FDh received
  std::uint32_t cycles_since_fresh = 0;
};

struct DriveCounters {
  std::uint64_t tpdos = 0;         // accepted
  std::uint64_t missed = 0;        // cycles after a SYNC with no TPDO from the drive
  std::uint64_t duplicates = 0;    // the same TPDO content twice in one cycle
  std::uint64_t late = 0;          // two different TPDOs in one cycle: the older came late
  std::uint64_t out_of_order = 0;  // a TPDO stamped earlier than one already accepted
  std::uint64_t malformed = 0;     // wrong DLC etc. from the drive's ids
  std::uint64_t statuswords = 0;   // statusword TPDO3s accepted (broadcast layout)
  std::uint64_t emcys = 0;
  std::uint64_t heartbeat_timeouts = 0;
  std::uint64_t boot_ups = 0;  // unexpected boot-up messages (node reset)
};

struct CanopenCounters {
  std::uint64_t cycles = 0;  // write() calls
  std::uint64_t sync_sent = 0;
  std::uint64_t tx_would_block = 0;      // ENOBUFS/EAGAIN: frame dropped, never retried
  std::uint64_t tx_errors = 0;           // other send failures
  std::uint64_t bus_off = 0;             // bus-off latches
  std::uint64_t recoveries = 0;          // successful recover_bus()
  std::uint64_t foreign_sync = 0;        // SYNC frames from another producer
  std::uint64_t sync_counter_jumps = 0;  // in received SYNCs with counter
  std::uint64_t unknown_frames = 0;      // ids outside the predefined set / unknown nodes
  std::uint64_t malformed_frames = 0;    // known function, undecodable
  std::uint64_t ignored_frames = 0;      // SDO, NMT, RPDOs of another master
  std::uint64_t heartbeats_sent = 0;
};

// What happened in the last read() + write(), one bit per drive (bit i = drive i).
struct CycleEvents {
  std::uint32_t emcy_raised = 0;
  std::uint32_t emcy_cleared = 0;
  std::uint32_t heartbeat_lost = 0;
  std::uint32_t boot_up = 0;  // a drive reset itself
  std::uint32_t nmt_not_operational = 0;
  std::uint32_t own_stop = 0;  // the drive stopped on its own (Cia402Drive::own_stop)
  std::uint32_t transition_timeout = 0;
  std::uint32_t stale = 0;       // no TPDO this cycle
  std::uint32_t stop_input = 0;  // the e-stop input (60FDh, TPDO2) became active
  bool bus_off = false;          // bus-off latched this cycle
  bool any() const noexcept {
    return (emcy_raised | heartbeat_lost | boot_up | nmt_not_operational | own_stop |
            transition_timeout | stop_input) != 0 ||
           bus_off;
  }
};

// What went on the wire for a drive in the last write().
struct SentCommand {
  std::uint16_t controlword = 0;
  std::int16_t torque_per_mille = 0;
  bool sent = false;  // false when the frame could not be sent (or bus-off)
};

// One line per drive for `dualv status` and logs (not real-time: allocates), e.g.
//   "node 2: ERROR (CiA 402 fault) NMT Operational, CiA 402 Fault, EMCY 4210h active
//    (device over temperature), own stop: fault, last TPDO 0 cycles ago"
std::string describe(const DriveHealthReport& h);

class CanopenActuatorSet final : public ActuatorSet {
 public:
  // Validates the configuration and the bus load (throws ConfigError with both numbers).
  // The bus and clock must outlive this object. Heartbeat monitoring starts now.
  CanopenActuatorSet(CanBus& bus, const canopen::Clock& clock, const CanConfig& config);

  int size() const noexcept override { return n_; }
  IoStatus read(ActuatorFeedback& feedback) noexcept override;
  IoStatus write(const ActuatorCommand& command) noexcept override;

  // Set-up: runs cycles with kHold (torque 0, voltage disabled) until every drive has
  // answered with a TPDO, so the first read() of the control loop has real positions.
  // Returns the drives that did not answer within timeout_ns (empty: all did).
  std::uint32_t prime(canopen::Waiter& waiter, std::uint64_t timeout_ns);
  // Non-RT idle service between set-up and the loop: drains frames and keeps the master's
  // heartbeat going (the drives watch it), without SYNC or RPDOs.
  void service() noexcept;

  // Set-up code, after the loop (issue 13 defect 6): leaves the drives in a defined state.
  // `cycles` cycles (at least 1) of disable voltage with target torque 0, each with its
  // SYNC (so drives with synchronous RPDOs act on them), one SYNC period apart, paced by
  // `waiter`; then NMT as can.on_exit says: enter pre-operational (PDOs stop, SDO stays),
  // stop, or nothing (operational, voltage disabled). Every step is logged (one line each,
  // naming the drives and the CiA 402 state each reported). Never throws for a drive that
  // does not answer (it is named in the log); on bus-off only the log line is written.
  // Returns true when every drive reported a disabled state (not Operation enabled).
  bool shut_down(canopen::Waiter& waiter, const std::function<void(const std::string&)>& log,
                 int cycles = 5);

  // Bus-off: latched until recover_bus() succeeds (it restarts the controller, which
  // discards everything queued before the fault). Afterwards every drive is disabled and
  // needs a new kEnable: no automatic return to Operation enabled.
  bool bus_off_latched() const noexcept { return bus_off_; }
  BusStatus recover_bus() noexcept;

  DriveHealthReport health(int drive) const noexcept;
  const DriveCounters& drive_counters(int drive) const noexcept { return drive_counters_[drive]; }
  const CanopenCounters& counters() const noexcept { return counters_; }
  const CycleEvents& events() const noexcept { return events_; }
  const SentCommand& last_sent(int drive) const noexcept { return sent_[drive]; }
  const Cia402Drive& drive(int i) const noexcept { return drives_[i]; }
  const canopen::HeartbeatConsumer& heartbeat(int i) const noexcept { return heartbeats_[i]; }
  const canopen::EmcyConsumer& emcy(int i) const noexcept { return emcys_[i]; }
  const fw::LayoutLoad& bus_load() const noexcept { return bus_load_; }
  const CanConfig& config() const noexcept { return config_; }
  CanBus& bus() noexcept { return bus_; }

 private:
  void dispatch(const fw::CanFrame& f, std::uint64_t now) noexcept;
  void on_tpdo(int i, const fw::CanFrame& f) noexcept;
  void on_statusword_tpdo(int i, const fw::CanFrame& f) noexcept;
  // Broadcast layout: a statusword came within statusword_bound_cycles_ (always true
  // per_drive and fd, where every TPDO1 carries it).
  bool statusword_current(int i) const noexcept;
  void lose(int i) noexcept;
  void latch_bus_off() noexcept;
  BusStatus send(const fw::CanFrame& f) noexcept;
  bool operational(int i) const noexcept;

  CanBus& bus_;
  const canopen::Clock& clock_;
  CanConfig config_;  // copied at set-up; never touched in the cycle but for reading
  int n_ = 0;
  fw::LayoutLoad bus_load_{};
  std::array<std::int8_t, fw::kMaxNodeId + 1> drive_of_node_{};
  std::array<Cia402Drive, kMaxDrives> drives_{};
  std::array<canopen::HeartbeatConsumer, kMaxDrives> heartbeats_{};
  std::array<canopen::EmcyConsumer, kMaxDrives> emcys_{};
  std::array<DriveCounters, kMaxDrives> drive_counters_{};
  std::array<SentCommand, kMaxDrives> sent_{};
  // Per-drive cycle state.
  std::array<std::uint16_t, kMaxDrives> statusword_{};
  std::array<std::int32_t, kMaxDrives> position_{};
  std::array<std::uint64_t, kMaxDrives> tpdo_stamp_{};
  std::array<std::uint32_t, kMaxDrives> digital_inputs_{};  // 60FDh, TPDO2
  std::array<std::uint8_t, kMaxDrives> tpdos_this_cycle_{};
  std::array<bool, kMaxDrives> ever_fresh_{};
  std::array<bool, kMaxDrives> fresh_{};
  std::array<std::uint32_t, kMaxDrives> cycles_since_fresh_{};
  std::array<double, kMaxDrives> torque_applied_{};              // [N m] last torque sent
  std::array<std::uint64_t, kMaxDrives> controlword_sent_ns_{};  // broadcast layout
  std::array<std::uint16_t, kMaxDrives> last_controlword_{};
  std::array<bool, kMaxDrives> controlword_ok_{};
  std::array<bool, kMaxDrives> statusword_seen_{};  // broadcast: TPDO3 seen
  std::array<std::uint32_t, kMaxDrives> cycles_since_statusword_{};
  std::uint32_t statusword_bound_cycles_ = 0;
  canopen::SyncProducer sync_;
  canopen::HeartbeatProducer heartbeat_producer_;
  bool sync_sent_last_cycle_ = false;
  std::uint64_t cycle_now_ns_ = 0;  // read()'s time for this cycle's write(); 0 = none
  std::uint8_t foreign_sync_counter_ = 0;
  bool bus_off_ = false;
  std::uint64_t cycle_ = 0;
  CycleEvents events_{};
  CycleEvents write_events_{};  // from write(), reported by the next read() too
  CanopenCounters counters_{};
};

}  // namespace dualv::drivers
