#pragma once
// n CiA 402 drives (CANopen slaves, CiA 301 + CiA 402-2) on one CanBus, driving the
// simulated plant: the other end of the wire from drivers/canopen*. Every index, COB-ID and
// bit mask comes from firmware_if; nothing here redefines one.
//
// Deterministic and event-driven: no threads, no sleeps, no clock of its own. The caller
// owns time and drives the emulator with
//   poll(now_ns)               receive every pending frame (on_frame), then on_time(now_ns)
//   on_frame(frame, now_ns)    one received frame
//   on_time(now_ns)            timers: boot, heartbeat producer, heartbeat consumer, RPDO
//                              deadline (1400h sub5), free run of the plant without SYNC
// The in-process rig (sim/in_process_can_rig.hpp) steps it with simulated time; `dualv sim`
// (apps/cmd_sim.cpp) with CLOCK_MONOTONIC on SocketCAN. All of these are noexcept and
// allocate nothing (the object dictionary, PDO maps and SDO buffers are fixed arrays built
// by the constructor).
//
// Each drive (slot i = plant joint i, node id from the configuration) is a CANopen slave
// assembled from the parts of sim/canopen/ (docs/architecture.md "CAN contract"); it has:
//  - NMT (CiA 301 7.3.2): Initialisation -> boot-up message (700h + id, 00h) ->
//    Pre-operational; start / stop / enter pre-op / reset node / reset communication.
//    SDO in Pre-operational and Operational; PDOs (and SYNC-driven TPDOs) in Operational
//    only; EMCY not in Stopped. Reset node restores the whole dictionary and the CiA 402
//    state (Switch on disabled, fault cleared); reset communication restores 1000h..1FFFh.
//  - an object dictionary: every od:: entry of firmware_if, 1016h sub0..2, and the
//    communication + mapping records of RPDO1..4 / TPDO1..4 (1400h..1A03h). Defaults:
//    RPDO1 = controlword + target torque (200h + id, synchronous), TPDO1 = statusword +
//    position actual (180h + id, every SYNC), the other PDOs not valid. 6076h, 608Fh and
//    6072h come from the `can:` drive entry.
//  - an SDO server (600h + id -> 580h + id): expedited and segmented download and upload
//    (segmented upload of the <= 4-byte objects when DriveEmulatorConfig::segmented_upload
//    is set: legal per CiA 301, it exercises a client's segmented path). Aborts: 06020000h
//    unknown object, 06090011h unknown subindex, 06010002h read-only, 06010001h write-only,
//    06070012h / 06070013h wrong size, 06090030h..32h bad values, 05030000h toggle,
//    05040001h bad command, 06040041h / 06040042h bad mappings, 06010000h mapping written
//    while the PDO is valid or sub0 is not 0 (CiA 301 7.5.2.36: invalidate, sub0 = 0,
//    entries, sub0 = n, validate).
//  - PDOs as mapped by the master (CiA 301 7.4.7.1), including dummy entries (0002h..0007h)
//    in RPDOs, so the broadcast layout of firmware_if/pdo.hpp works as written: the master
//    sets RPDO2's COB-ID to 200h and maps broadcast_rpdo_layout(slot, n).
//    RPDO transmission types 0..240 are synchronous: the data is latched at the next SYNC
//    (CiA 301 7.2.2.2); 254/255 act on reception. TPDO types 1..240 are sent every n-th
//    SYNC; 0, 254 and 255 at a SYNC when their content changed, and on their event timer
//    (1800h sub5, restarted by every transmission). The inhibit time (1800h sub3, 100 us)
//    is the least spacing of two transmissions of a TPDO (CiA 301 7.5.2.37): a change
//    inside it is sent when it ends (on_time, with the data of that moment).
//    An RPDO shorter than its mapping is dropped with EMCY 8210h.
//  - the CiA 402 state machine (CiA 402-2 6.2, firmware_if/cia402.hpp) driven by the
//    controlword 6040h: transitions 2..12 and 15 (fault reset on the rising edge of bit 7
//    only), 16 only when 605Ah is 5..8. Quick stop (11, and the 6007h reaction): torque
//    off at once (the deceleration ramp is not modelled); with 605Ah 0 the drive goes to
//    Switch on disabled at once, with 1..4 at the next SYNC, with 5..8 it stays in Quick
//    stop active. A fault passes Fault reaction active within the same event (torque off,
//    no ramp) and lands in Fault. Modes: 6060h accepts 0 and 10 (cyclic synchronous
//    torque, the only mode in 6502h); 6061h follows. Statusword = the state's pattern,
//    + remote (bit 9), + voltage enabled (bit 4) in Switched on / Operation enabled /
//    Quick stop active, + drive follows the command (bit 12) in Operation enabled with
//    mode 10, + internal limit active (bit 11) while 6072h clips the target, + warning
//    (bit 7) while the e-stop input is active.
//  - target torque 6071h [per mille of 6076h] -> clipped to +-6072h -> N m into the plant,
//    only in Operation enabled with mode 10; 0 N m in every other state.
//  - heartbeat producer 1017h [ms] and consumer 1016h sub1..2 (node << 16 | ms; monitoring
//    starts with the first heartbeat received from that node, CiA 301 7.2.8.3.2.2). A
//    silence of >= the consumer time sends EMCY 8130h and performs the 6007h reaction
//    (1 fault, 2 disable voltage, 3 quick stop); the heartbeat coming back sends EMCY 0000h
//    when no fault is pending. The 6007h reaction is also performed when NMT leaves
//    Operational (stop, pre-operational, reset communication) with the drive in Operation
//    enabled, since its RPDOs are no longer processed (CiA 402-2 6007h events).
//  - a drive-side RPDO watchdog (EtherCAT's sync-manager watchdog): at every SYNC with no
//    new RPDO carrying 6071h since the previous SYNC a miss is counted; at
//    rpdo_watchdog_cycles consecutive misses the torque is removed from that SYNC on and a
//    drive in Operation enabled goes to Fault with EMCY 8250h. Armed by the first such
//    RPDO in Operational. The RPDO event timer 1400h sub5 (deadline monitoring, CiA 301)
//    is checked in on_time with the same reaction.
//  - digital inputs 60FDh; the hardwired e-stop circuit is wired to od::kDigitalInputEstopBit
//    (press_estop()): while active the power stage is off (STO): torque 0, a drive in
//    Switched on .. Quick stop active drops to Switch on disabled, and transition 2 is
//    refused. No EMCY: the host sees it in 60FDh (mapped into a TPDO or read by SDO) and
//    the statusword warning bit.
//  - fault injection: inject_fault (EMCY code), set_silent (no frame in or out: cable
//    unplugged; its own watchdogs keep running), set_refuse_boot (stays in Initialisation,
//    silent, after power-on or reset), drop_tpdos, inject_encoder_offset (an encoder jump).
//
// Timing (one cycle of transport delay, like a real drive in cyclic synchronous mode):
//   at SYNC k (time t_k): 1) the plant is advanced from t_{k-1} to t_k with the torque
//   latched at SYNC k-1 (nothing at the first SYNC: plant time starts there), by the
//   actual spacing of the SYNCs received (their receive timestamps when the bus gives
//   them, else the time they were handled): the mechanism moves in real time whatever
//   period the master runs at. 1006h only monitors the SYNC (late_syncs());
//   2) every drive samples its TPDO data (position actual = plant counts + zero_offset,
//   statusword, ...) and sends its due TPDOs; 3) synchronous RPDOs received since SYNC
//   k-1 are latched, the watchdog counted, quick stops completed; 4) the new torque is
//   handed to the plant (Plant::command), acting from t_k to t_{k+1}.
//   So a torque computed by the host from the TPDO of SYNC k-1 acts from t_k on. Events
//   between two SYNCs that remove torque (fault, e-stop, controlword) re-command the plant
//   at once: they act on the whole current period (resolution: one SYNC period).
//   Because the bus provides this one cycle, the plant used behind the emulator must not
//   add it again: emulator_plant_config() turns the plant's transport delay into
//   (cycles - 1) and its torque quantisation off (the per mille quantisation happens on
//   the wire, 6071h is an integer).
//   When SYNCs stop for free_run_after_ns after having started (the master died), the
//   plant keeps running in on_time in whole nominal periods (1006h when written, else the
//   `can:` SYNC period) ("virtual SYNCs": no TPDO, the
//   watchdog counts misses), so a dead master does not freeze the mechanism mid-motion.
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "drivers/can/can_bus.hpp"
#include "firmware_if/can_config.hpp"
#include "firmware_if/firmware_if.hpp"
#include "sim/plant.hpp"

namespace dualv::sim {

namespace canopen {
class ObjectDictionary;
}

inline constexpr int kMaxEmulatedDrives = model::kMaxChains;
inline constexpr std::uint8_t kEmulatedPdos = 4;                // RPDO1..4, TPDO1..4
inline constexpr std::uint8_t kEmulatedConsumerHeartbeats = 2;  // 1016h sub1..2

struct DriveEmulatorDrive {
  std::uint8_t node_id = 1;
  std::uint32_t counts_per_revolution = 1u << 20;  // 608Fh sub1 (sub2 = 1)
  std::uint32_t rated_torque_mnm = 50'000;         // 6076h default [mN m]
  std::uint16_t max_torque_per_mille = 2540;       // 6072h default
  std::int32_t zero_offset = 0;                    // [counts] position actual at joint angle 0
};

struct DriveEmulatorConfig {
  std::vector<DriveEmulatorDrive> drives;    // drive i = plant joint i; size = plant.size()
  std::uint64_t sync_period_ns = 1'000'000;  // nominal plant step per SYNC (1006h overrides)
  // Defaults of the objects the master normally configures (CiA 301 / 402 objects).
  std::uint16_t producer_heartbeat_ms = 0;  // 1017h
  std::uint32_t consumer_heartbeat = 0;     // 1016h sub1 (node << 16 | ms), 0 = off
  fw::AbortConnectionOption abort_connection = fw::AbortConnectionOption::kQuickStop;  // 6007h
  fw::QuickStopOption quick_stop = fw::QuickStopOption::kQuickStopRamp;                // 605Ah
  fw::FaultReactionOption fault_reaction = fw::FaultReactionOption::kQuickStopRamp;    // 605Eh
  // Drive-side watchdog: consecutive SYNCs without a new target-torque RPDO before the
  // torque is removed; 0 = off.
  std::uint32_t rpdo_watchdog_cycles = 3;
  // Plant free run without SYNC (see the header comment); 0 = never.
  std::uint64_t free_run_after_ns = 50'000'000;
  // Advance the mechanism by 1006h per SYNC instead of by the SYNCs' actual spacing: for a
  // test guest that its host freezes as a whole (tests/hil/README.md), whose clock jumps while
  // neither the master nor the drives ran; the spacing is then not time a drive saw.
  bool plant_step_nominal = false;
  // Answer every upload with a segmented transfer (legal, tests the client's path).
  bool segmented_upload = false;
  // A foreign drive's habits (`dualv sim --foreign`): expedited upload responses without
  // size indication (42h + 4 bytes, CiA 301 7.2.4.3.6), and objects the drive does not
  // have (SDO answers 06020000h). Only objects a CiA 402 CST drive may lack can be left
  // out: 1006h, 1019h, 6007h, 605Ah..605Eh, 606Ch, 6077h, 60C2h, 60FDh.
  bool upload_without_size = false;
  std::vector<std::uint16_t> absent_objects;
  // A drive that cannot map CiA 301 dummy entries (0002h..0007h): the write of such a
  // mapping entry is aborted with 06040041h (`dualv sim --no-dummy-mapping`).
  bool refuse_dummy_mapping = false;
  // A CAN FD drive (CiA 1301): PDOs up to 64 bytes, every TPDO sent as an FD frame with BRS,
  // FD RPDOs received (the classic frames too). False: a classic drive, a mapping longer
  // than 8 bytes aborted with 06040042h and FD frames ignored. emulator_config_from() sets it
  // for can.bus_layout: fd; `dualv sim --no-fd` clears it.
  bool fd = false;
  std::uint32_t vendor_id = 0x00000000;     // 1018h sub1 (none registered: a simulator)
  std::uint32_t product_code = 0x44564531;  // 1018h sub2, "DVE1"

  // Checks the set-up; throws std::invalid_argument saying what to fix.
  void validate(int plant_joints) const;
};

// The emulator's view of the `can:` section (firmware_if/can_config.hpp): node ids, units,
// offsets, SYNC period, and as defaults the values the master writes at boot anyway.
DriveEmulatorConfig emulator_config_from(const fw::CanConfig& can);

// The plant behind the emulator: `plant` with its torque quantisation off (the wire
// quantises) and its transport delay reduced by the one cycle the bus provides
// (cycles 1 -> off); its encoder resolution set to the drives' (throws
// std::invalid_argument when the drives disagree).
PlantConfig emulator_plant_config(const PlantConfig& plant, const DriveEmulatorConfig& emu);

// Emulator-side NMT state (CiA 301 figure 48), including Initialisation.
enum class EmulatedNmt : std::uint8_t { kInitialisation, kPreOperational, kOperational, kStopped };
const char* to_string(EmulatedNmt s) noexcept;

struct EmulatedDriveCounters {
  std::uint64_t syncs = 0;  // SYNCs processed (Operational or not)
  std::uint64_t rpdos = 0;  // RPDOs accepted
  std::uint64_t rpdo_length_errors = 0;
  std::uint64_t tpdos_sent = 0;
  std::uint64_t tpdos_dropped = 0;  // by drop_tpdos
  std::uint64_t sdo_requests = 0;
  std::uint64_t sdo_aborts_sent = 0;
  std::uint64_t emcy_sent = 0;
  std::uint64_t heartbeats_sent = 0;
  std::uint64_t heartbeat_losses = 0;
  std::uint64_t watchdog_trips = 0;        // SYNC-counted RPDO watchdog
  std::uint64_t deadline_trips = 0;        // 1400h sub5 event timer
  std::uint64_t tx_failures = 0;           // CanBus::send did not return kOk
  std::uint64_t fault_resets_refused = 0;  // transition 15 asked while the cause remains
};

// A snapshot of one drive, for tests, the CLI status line and fault-injection suites.
struct EmulatedDriveStatus {
  std::uint8_t node_id = 0;
  EmulatedNmt nmt = EmulatedNmt::kInitialisation;
  fw::Cia402State state = fw::Cia402State::kNotReadyToSwitchOn;
  std::uint8_t last_transition = 0;  // CiA 402 transition number, 0 = none yet
  std::uint16_t statusword = 0;
  std::uint16_t controlword = 0;
  std::int16_t target_torque = 0;     // 6071h as last latched [per mille]
  double torque_nm = 0.0;             // what this drive commands the plant now [N m]
  std::int32_t position = 0;          // 6064h at the last sample [counts]
  std::uint16_t error_code = 0;       // 603Fh
  std::uint8_t error_register = 0;    // 1001h
  std::uint32_t digital_inputs = 0;   // 60FDh
  std::uint32_t watchdog_missed = 0;  // consecutive SYNCs without a torque RPDO
  bool heartbeat_lost = false;        // master heartbeat currently lost
  bool silent = false;
  EmulatedDriveCounters counters{};
};

class DriveEmulator {
 public:
  // n = plant.size() drives. Set-up: validates `config` (std::invalid_argument naming the
  // problem) and builds every dictionary; sends nothing (the drives power on at the first
  // on_time / poll). `bus` and `plant` must outlive the emulator; the plant should be built
  // with emulator_plant_config().
  DriveEmulator(drivers::CanBus& bus, Plant& plant, const DriveEmulatorConfig& config);
  ~DriveEmulator();
  DriveEmulator(const DriveEmulator&) = delete;
  DriveEmulator& operator=(const DriveEmulator&) = delete;

  // ---- the frame path (noexcept, no allocation) -------------------------------------
  // Receives every pending frame (each handled at now_ns), then on_time(now_ns). Returns
  // the number of frames received.
  std::size_t poll(std::uint64_t now_ns) noexcept;
  void on_frame(const fw::CanFrame& frame, std::uint64_t now_ns) noexcept;
  void on_time(std::uint64_t now_ns) noexcept;
  // The earliest time (>= now_ns) at which on_time has something to do: heartbeats, consumer
  // heartbeat and RPDO deadlines, event TPDOs, the plant's free run; kNever when nothing is
  // scheduled. A process that owns the emulator sleeps until then or until a frame arrives
  // (apps/cmd_sim.cpp), instead of waking on a fixed tick.
  static constexpr std::uint64_t kNever = ~std::uint64_t{0};
  std::uint64_t next_due_ns(std::uint64_t now_ns) const noexcept;

  // ---- inputs and fault injection (tests, CLI); noexcept ------------------------------
  // The e-stop circuit: every drive's 60FDh e-stop bit (the circuit is shared).
  void press_estop(bool pressed) noexcept;
  // One drive's digital inputs (60FDh): set or clear the bits of `mask`.
  void set_digital_inputs(int drive, std::uint32_t mask, bool on) noexcept;
  // The drive faults now (transition 13 -> 14): EMCY with `emcy_code`, 603Fh, torque off.
  // A fault reset (transition 15) clears it at once.
  void inject_fault(int drive, std::uint16_t emcy_code) noexcept;
  // The same, with a cause that remains (e.g. over-temperature) until release_fault(): a
  // fault reset is refused while it does (the drive stays in Fault), and works after.
  void hold_fault(int drive, std::uint16_t emcy_code) noexcept;
  void release_fault(int drive) noexcept;
  // No frame in or out (cable unplugged); internal timers keep running.
  void set_silent(int drive, bool silent) noexcept;
  // After power-on or a reset the drive stays in Initialisation, silent. Clearing it boots
  // the drive at the next on_time (as if powered on).
  void set_refuse_boot(int drive, bool refuse) noexcept;
  // The next n TPDOs of the drive are not sent (kForever: all of them until called with 0).
  static constexpr std::uint32_t kForever = std::numeric_limits<std::uint32_t>::max();
  void drop_tpdos(int drive, std::uint32_t n) noexcept;
  // Adds `counts` to the drive's position actual from now on (an encoder jump).
  void inject_encoder_offset(int drive, std::int32_t counts) noexcept;

  // ---- observation -----------------------------------------------------------------
  int size() const noexcept { return n_; }
  EmulatedDriveStatus status(int drive) const noexcept;
  // The raw value of an object of a drive (as the SDO server would answer, without
  // refreshing live values); false when the object does not exist.
  bool read_object(int drive, std::uint16_t index, std::uint8_t subindex,
                   std::uint32_t& raw) const noexcept;
  bool estop_pressed() const noexcept { return estop_; }
  std::uint64_t syncs() const noexcept { return syncs_; }
  // SYNC monitoring with 1006h (CiA 301 7.5.2.6): SYNCs that came more than 1.5 x 1006h
  // after the previous one (0 when 1006h is 0).
  std::uint64_t late_syncs() const noexcept { return late_syncs_; }
  std::uint64_t virtual_syncs() const noexcept { return virtual_syncs_; }
  std::uint64_t unhandled_frames() const noexcept { return unhandled_frames_; }
  std::uint64_t last_frame_ns() const noexcept { return last_frame_ns_; }
  Plant& plant() noexcept { return plant_; }
  const Plant& plant() const noexcept { return plant_; }
  const DriveEmulatorConfig& config() const noexcept { return config_; }
  // Drive `drive`'s object dictionary (0..size()-1), as built: what its SDO server answers
  // (checked against an EDS by sim/canopen/eds_dictionary.hpp).
  const canopen::ObjectDictionary& dictionary(int drive) const noexcept;

 private:
  // One slave, wired from the parts of sim/canopen/ (object dictionary, SDO server, PDO
  // engine, NMT slave + heartbeat producer, EMCY producer, CiA 402 slave) with the drive's
  // physics, heartbeat consumer, 6007h reactions and RPDO watchdog (the .cpp).
  struct Drive;

  void sync(std::uint64_t now_ns, bool real, std::uint64_t stamp_ns = 0) noexcept;
  void command_plant() noexcept;
  double period_s() const noexcept;

  drivers::CanBus& bus_;
  Plant& plant_;
  DriveEmulatorConfig config_;
  int n_ = 0;
  // No {} here: clang would need Drive complete to destroy the elements of a braced init.
  std::array<std::unique_ptr<Drive>, kMaxEmulatedDrives> drives_;  // built once, null before
  bool powered_ = false;
  bool estop_ = false;
  bool plant_started_ = false;         // a SYNC has been seen: plant time runs
  bool free_running_ = false;          // SYNCs stopped: on_time advances the plant
  std::uint64_t last_advance_ns_ = 0;  // time of the last (real or virtual) SYNC
  std::uint64_t last_real_sync_ns_ = 0;
  std::uint64_t last_sync_stamp_ns_ = 0;  // receive timestamp of the last real SYNC, 0 = none
  bool last_advance_real_ = false;
  std::uint64_t syncs_ = 0;
  std::uint64_t late_syncs_ = 0;
  std::uint64_t virtual_syncs_ = 0;
  std::uint64_t unhandled_frames_ = 0;
  std::uint64_t last_frame_ns_ = 0;
  model::JointVector torque_;  // [N m] handed to the plant
};

}  // namespace dualv::sim
