#include "sim/drive_emulator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "sim/canopen/cia402_slave.hpp"
#include "sim/canopen/emcy_producer.hpp"
#include "sim/canopen/heartbeat_consumer.hpp"
#include "sim/canopen/nmt_slave.hpp"
#include "sim/canopen/object_dictionary.hpp"
#include "sim/canopen/pdo_engine.hpp"
#include "sim/canopen/sdo_server.hpp"

namespace dualv::sim {

namespace {

using fw::Cia402State;
using fw::OdEntry;
using fw::SdoAbortCode;
using fw::od::PdoDirection;

constexpr std::uint32_t kNoAbort = 0;

constexpr std::uint32_t abort_value(SdoAbortCode c) noexcept {
  return static_cast<std::uint32_t>(c);
}

using canopen::as_signed;
using canopen::mask_of;

// The objects a foreign drive may lack (DriveEmulatorConfig::absent_objects).
bool may_be_absent(std::uint16_t index) noexcept {
  switch (index) {
    case 0x1006:
    case 0x1019:
    case 0x6007:
    case 0x605A:
    case 0x605B:
    case 0x605C:
    case 0x605D:
    case 0x605E:
    case 0x606C:
    case 0x6077:
    case 0x60C2:
    case 0x60FD:
      return true;
    default:
      return false;
  }
}

}  // namespace

const char* to_string(EmulatedNmt s) noexcept {
  switch (s) {
    case EmulatedNmt::kInitialisation:
      return "INIT";
    case EmulatedNmt::kPreOperational:
      return "PRE-OP";
    case EmulatedNmt::kOperational:
      return "OP";
    case EmulatedNmt::kStopped:
      return "STOPPED";
  }
  return "?";
}

// ---- configuration -------------------------------------------------------------------

void DriveEmulatorConfig::validate(int plant_joints) const {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("drive emulator: " + what);
  };
  if (drives.empty()) fail("no drives configured (can.drives is empty)");
  if (static_cast<int>(drives.size()) > kMaxEmulatedDrives)
    fail(std::to_string(drives.size()) + " drives, at most " + std::to_string(kMaxEmulatedDrives));
  if (static_cast<int>(drives.size()) != plant_joints)
    fail(std::to_string(drives.size()) + " drives for a plant of " + std::to_string(plant_joints) +
         " joints: configure one drive per joint (can.drives)");
  for (std::size_t i = 0; i < drives.size(); ++i) {
    const DriveEmulatorDrive& d = drives[i];
    const std::string who =
        "drive " + std::to_string(i) + " (node " + std::to_string(d.node_id) + ")";
    if (!fw::is_valid_node_id(d.node_id)) fail(who + ": node id must be 1..127");
    for (std::size_t j = 0; j < i; ++j)
      if (drives[j].node_id == d.node_id) fail(who + ": node id used twice");
    if (d.counts_per_revolution == 0) fail(who + ": counts_per_revolution must be > 0");
    if (d.rated_torque_mnm == 0) fail(who + ": rated torque must be > 0");
  }
  if (sync_period_ns == 0) fail("SYNC period must be > 0");
  for (std::uint16_t idx : absent_objects)
    if (!may_be_absent(idx)) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "%04Xh", idx);
      fail(std::string("object ") + buf +
           " cannot be left out: only 1006h, 1019h, 6007h, 605Ah..605Eh, 606Ch, 6077h, 60C2h "
           "and 60FDh are optional for a CiA 402 cyclic synchronous torque drive");
    }
}

DriveEmulatorConfig emulator_config_from(const fw::CanConfig& can) {
  DriveEmulatorConfig c;
  for (const fw::CanDriveConfig& d : can.drives) {
    DriveEmulatorDrive e;
    e.node_id = d.node_id;
    e.counts_per_revolution = d.counts_per_revolution;
    e.rated_torque_mnm = static_cast<std::uint32_t>(std::llround(d.rated_torque * 1000.0));
    e.max_torque_per_mille = fw::max_torque_per_mille(d.max_torque, d.rated_torque);
    e.zero_offset = d.zero_offset;
    c.drives.push_back(e);
  }
  c.sync_period_ns = can.sync_period_ns;
  c.fd = can.bus_layout == fw::BusLayout::kFd;
  c.abort_connection = can.abort_connection;
  c.quick_stop = can.quick_stop;
  c.fault_reaction = can.fault_reaction;
  // 1017h and 1016h are written by the master at boot; until then the drives are silent
  // apart from their boot-up message, as most drives are out of the box.
  return c;
}

PlantConfig emulator_plant_config(const PlantConfig& plant, const DriveEmulatorConfig& emu) {
  PlantConfig p = plant;
  // The wire quantises: 6071h is an integer per mille of 6076h.
  p.torque_quantisation.enabled = false;
  // The bus provides one cycle of transport delay (SYNC-latched torque, see the header).
  if (p.transport_delay.enabled) {
    p.transport_delay.cycles -= 1;
    if (p.transport_delay.cycles <= 0) {
      p.transport_delay.enabled = false;
      p.transport_delay.cycles = 1;  // unused when disabled; keeps the loader's range
    }
  }
  if (!emu.drives.empty()) {
    const std::uint32_t cpr = emu.drives.front().counts_per_revolution;
    for (const DriveEmulatorDrive& d : emu.drives)
      if (d.counts_per_revolution != cpr)
        throw std::invalid_argument(
            "drive emulator: every drive needs the same counts_per_revolution (the plant has "
            "one encoder resolution); node " +
            std::to_string(d.node_id) + " has " + std::to_string(d.counts_per_revolution) +
            ", node " + std::to_string(emu.drives.front().node_id) + " has " + std::to_string(cpr));
    p.encoder.counts_per_revolution = cpr;
  }
  return p;
}

static_assert(kEmulatedConsumerHeartbeats == canopen::kHeartbeatConsumers,
              "1016h sub1..n: the emulator's entries are the consumer part's");

// ---- one slave ---------------------------------------------------------------------------

struct DriveEmulator::Drive {
  int index = 0;  // plant joint
  std::uint8_t node = 1;
  DriveEmulatorDrive cfg{};

  canopen::ObjectDictionary dict;
  // Slots of the objects the emulator acts on.
  int s_cw = -1, s_sw = -1, s_tt = -1, s_mode = -1, s_mode_disp = -1, s_pos = -1, s_vel = -1,
      s_torque = -1, s_din = -1, s_err = -1, s_err_reg = -1, s_hb_prod = -1, s_abort = -1,
      s_qs = -1, s_max = -1, s_rated = -1, s_sync = -1, s_period = -1;
  std::array<int, kEmulatedConsumerHeartbeats> s_hb_cons{};

  canopen::PdoEngine pdos;

  canopen::NmtSlave nmt;       // with the heartbeat producer 1017h
  canopen::EmcyProducer emcy;  // and the error register 1001h
  canopen::Cia402Slave cia;    // the CiA 402 state machine, from firmware_if's table
  bool limit_active = false;
  double torque_nm = 0.0;

  // NMT error control.
  canopen::HeartbeatConsumer hb_consumer;  // 1016h: the master's heartbeat

  // Error conditions behind the error register 1001h (canopen::EmcyProducer: each sends its
  // EMCY when it starts and EMCY 0000h with the remaining register when it is gone).
  enum Condition : int {
    kFaultCondition,                                            // CiA 402 Fault, with 603Fh
    kHeartbeatLost,                                             // + consumer 0..1 (8130h)
    kPdoLength = kHeartbeatLost + kEmulatedConsumerHeartbeats,  // 8210h: RPDO too short
    kDeadline,  // 8250h: the RPDO deadline (1400h sub5) expired
    kWatchdog,  // 8250h: the SYNC-counted RPDO watchdog tripped
  };
  bool fault_cause = false;  // hold_fault(): transition 15 refused while set

  // RPDO watchdog.
  bool wd_armed = false;
  bool torque_rx_since_sync = false;
  std::uint32_t wd_missed = 0;
  bool wd_tripped = false;

  // Injection.
  bool silent = false;
  bool refuse_boot = false;
  bool boot_pending = false;
  std::uint32_t drop_tpdos = 0;
  std::int32_t encoder_offset = 0;
  std::uint32_t hw_inputs = 0;  // 60FDh as wired

  canopen::SdoServer sdo_server;

  EmulatedDriveCounters counters{};

  // ---- dictionary (sim/canopen/object_dictionary.hpp) ----
  int find(std::uint16_t idx, std::uint8_t sub) const noexcept { return dict.find(idx, sub); }
  int find(const OdEntry& e) const noexcept { return dict.find(e); }
  bool has_index(std::uint16_t idx) const noexcept { return dict.has_index(idx); }
  int add(const OdEntry& e, std::uint32_t initial) { return dict.add(e, initial); }
  const OdEntry& entry(int slot) const noexcept { return dict.entry(slot); }
  std::uint32_t u(int slot) const noexcept { return dict.u(slot); }
  std::int32_t i(int slot) const noexcept { return dict.i(slot); }
  void set(int slot, std::uint32_t v) noexcept { dict.set(slot, v); }

  void build(const DriveEmulatorConfig& c, int joint) {
    namespace od = fw::od;
    index = joint;
    dict.set_absent(c.absent_objects);
    pdos.configure({c.fd, c.refuse_dummy_mapping});
    sdo_server.configure(c.drives[static_cast<std::size_t>(joint)].node_id,
                         {c.segmented_upload, c.upload_without_size});
    cfg = c.drives[static_cast<std::size_t>(joint)];
    node = cfg.node_id;
    add(od::kDeviceType, 0x00020000u | od::kDeviceProfileCia402);  // servo drive, CiA 402
    s_err_reg = add(od::kErrorRegister, 0);
    s_sync = add(od::kCobIdSync, fw::kSyncCobId);
    s_period =
        add(od::kCommunicationCyclePeriod, static_cast<std::uint32_t>(c.sync_period_ns / 1000u));
    add(od::kCobIdEmcy, fw::cob_id(fw::Function::kEmcy, node));
    add(od::kConsumerHeartbeatCount, kEmulatedConsumerHeartbeats);
    for (std::uint8_t s = 1; s <= kEmulatedConsumerHeartbeats; ++s)
      s_hb_cons[s - 1u] = add(od::consumer_heartbeat(s), s == 1 ? c.consumer_heartbeat : 0u);
    s_hb_prod = add(od::kProducerHeartbeat, c.producer_heartbeat_ms);
    nmt.attach(node, s_hb_prod);
    hb_consumer.attach(s_hb_cons);
    emcy.attach(node, s_err_reg);
    // Every record has sub0, the highest sub-index supported (CiA 301 7.4.3).
    add(od::kIdentityCount, od::kIdentitySerial.subindex);
    add(od::kIdentityVendorId, c.vendor_id);
    add(od::kIdentityProductCode, c.product_code);
    add(od::kIdentityRevision, 0x00010000u);
    add(od::kIdentitySerial, node);
    add(od::kSyncCounterOverflow, 0);
    s_abort = add(od::kAbortConnectionOption, static_cast<std::uint16_t>(c.abort_connection));
    s_err = add(od::kErrorCode, 0);
    s_cw = add(od::kControlword, 0);
    s_sw = add(od::kStatusword, 0);
    s_qs = add(od::kQuickStopOption, static_cast<std::uint16_t>(c.quick_stop));
    add(od::kShutdownOption, 0);
    add(od::kDisableOperationOption, 0);
    add(od::kHaltOption, static_cast<std::uint16_t>(fw::HaltOption::kSlowDownRamp));
    add(od::kFaultReactionOption, static_cast<std::uint16_t>(c.fault_reaction));
    s_mode = add(od::kModesOfOperation, 0);
    s_mode_disp = add(od::kModesOfOperationDisplay, 0);
    s_pos = add(od::kPositionActual, 0);
    s_vel = add(od::kVelocityActual, 0);
    s_tt = add(od::kTargetTorque, 0);
    s_max = add(od::kMaxTorque, cfg.max_torque_per_mille);
    s_rated = add(od::kRatedTorque, cfg.rated_torque_mnm);
    s_torque = add(od::kTorqueActual, 0);
    add(od::kEncoderResolutionCount, od::kEncoderMotorRevolutions.subindex);
    add(od::kEncoderIncrements, cfg.counts_per_revolution);
    add(od::kEncoderMotorRevolutions, 1);
    add(od::kInterpolationPeriodCount, od::kInterpolationPeriodIndex.subindex);
    add(od::kInterpolationPeriodValue, 1);
    add(od::kInterpolationPeriodIndex, static_cast<std::uint8_t>(-3));  // 1 x 10^-3 s
    s_din = add(od::kDigitalInputs, 0);
    add(od::kSupportedDriveModes, fw::supported_mode_bit(fw::ModeOfOperation::kCyclicSyncTorque));
    // PDO records (CiA 301 7.5.2.35..38): RPDO1 / TPDO1 as the contract's defaults.
    canopen::PdoEngine::add_objects(dict, node);
    pdos.rebuild(dict);
  }

  // ---- value checks for SDO downloads (CiA 301 table 22 codes) ----
  std::uint32_t check_write(int slot, std::uint32_t v) const noexcept {
    namespace fo = fw::od;
    const OdEntry& e = dict.entry(slot);
    const std::int32_t sv = as_signed(v, e.size());
    auto range = [&](std::int32_t lo, std::int32_t hi) -> std::uint32_t {
      if (sv < lo) return abort_value(SdoAbortCode::kValueTooLow);
      if (sv > hi) return abort_value(SdoAbortCode::kValueTooHigh);
      return kNoAbort;
    };
    if (e.same_object(fo::kCobIdSync.index, 0)) {
      // Bit 30 (this node generates SYNC) and bit 29 (29-bit id) are not supported.
      return (v & 0x60000000u) ? abort_value(SdoAbortCode::kInvalidValue) : kNoAbort;
    }
    if (e.same_object(fo::kSyncCounterOverflow.index, 0))
      return (v == 0 || (v >= fw::kSyncCounterOverflowMin && v <= fw::kSyncCounterOverflowMax))
                 ? kNoAbort
                 : abort_value(SdoAbortCode::kInvalidValue);
    if (e.same_object(fo::kAbortConnectionOption.index, 0)) return range(0, 3);
    if (e.same_object(fo::kQuickStopOption.index, 0)) return range(0, 8);
    if (e.same_object(fo::kShutdownOption.index, 0)) return range(0, 1);
    if (e.same_object(fo::kDisableOperationOption.index, 0)) return range(0, 1);
    if (e.same_object(fo::kHaltOption.index, 0)) return range(1, 4);
    if (e.same_object(fo::kFaultReactionOption.index, 0)) return range(0, 4);
    if (e.same_object(fo::kModesOfOperation.index, 0))
      return (sv == 0 || sv == static_cast<std::int8_t>(fw::ModeOfOperation::kCyclicSyncTorque))
                 ? kNoAbort
                 : abort_value(SdoAbortCode::kInvalidValue);
    if (e.same_object(fo::kRatedTorque.index, 0) || e.index == fo::kEncoderIncrements.index)
      return v == 0 ? abort_value(SdoAbortCode::kValueTooLow) : kNoAbort;
    return pdos.check_write(dict, e, v);
  }

  // ---- output ----
  // The drive's frames to the bus (none while silent).
  struct Sink final : canopen::FrameSink {
    Sink(Drive& d, DriveEmulator& e) noexcept : drive(d), emu(e) {}
    void send(const fw::CanFrame& f) noexcept override { drive.send(emu, f); }
    Drive& drive;
    DriveEmulator& emu;
  };
  EmulatedNmt nmt_state() const noexcept {
    switch (nmt.state()) {
      case canopen::NmtSlaveState::kInitialisation:
        return EmulatedNmt::kInitialisation;
      case canopen::NmtSlaveState::kPreOperational:
        return EmulatedNmt::kPreOperational;
      case canopen::NmtSlaveState::kOperational:
        return EmulatedNmt::kOperational;
      case canopen::NmtSlaveState::kStopped:
        return EmulatedNmt::kStopped;
    }
    return EmulatedNmt::kInitialisation;
  }
  void send(DriveEmulator& emu, const fw::Result<fw::CanFrame>& frame) noexcept {
    if (!frame || silent) return;
    if (emu.bus_.send(*frame) != drivers::BusStatus::kOk) ++counters.tx_failures;
  }
  // An error condition started: 1001h updated, then its EMCY (carrying 1001h) when
  // `announce` and NMT allows EMCY (Pre-operational, Operational: CiA 301 table 75).
  void raise(DriveEmulator& emu, int condition, std::uint16_t code, bool announce = true) noexcept {
    Sink sink(*this, emu);
    emcy.raise(dict, condition, code, announce && !silent && nmt.emcy_allowed(), sink);
  }
  // An error condition is gone: EMCY 0000h "error reset" with the remaining 1001h.
  void gone(DriveEmulator& emu, int condition, bool announce = true) noexcept {
    Sink sink(*this, emu);
    emcy.clear(dict, condition, announce && !silent && nmt.emcy_allowed(), sink);
  }
  // ---- CiA 402 (canopen::Cia402Slave; here what a state means for the drive) ----
  std::uint16_t statusword(bool estop_input) const noexcept {
    std::uint16_t extra = 0;
    if (cia.state() == Cia402State::kOperationEnabled && mode_is_cst()) {
      extra |= fw::sw::kDriveFollowsCommand;
      if (limit_active) extra |= fw::sw::kInternalLimitActive;
    }
    if (estop_input) extra |= fw::sw::kWarning;
    return cia.statusword(extra);
  }
  bool mode_is_cst() const noexcept {
    return i(s_mode) == static_cast<std::int8_t>(fw::ModeOfOperation::kCyclicSyncTorque);
  }
  bool estop_input() const noexcept { return (u(s_din) & fw::od::kDigitalInputEstopMask) != 0; }
  std::int16_t quick_stop_option() const noexcept { return static_cast<std::int16_t>(i(s_qs)); }

  // After the state machine moved: statusword, and torque off at once outside Operation
  // enabled (re-command the plant for the current period).
  void state_changed(DriveEmulator& emu) noexcept {
    set(s_sw, statusword(estop_input()));
    if (cia.state() != Cia402State::kOperationEnabled && torque_nm != 0.0) {
      torque_nm = 0.0;
      limit_active = false;
      emu.torque_[index] = 0.0;
      emu.command_plant();
    }
  }
  void enter_quick_stop(DriveEmulator& emu) noexcept {
    cia.quick_stop(quick_stop_option());
    state_changed(emu);
  }
  void disable_voltage(DriveEmulator& emu) noexcept {
    if (cia.disable_voltage()) state_changed(emu);
  }
  void enter_fault(DriveEmulator& emu, std::uint16_t code) noexcept {
    set(s_err, code);
    if (cia.fault()) state_changed(emu);
    raise(emu, kFaultCondition, code);
  }

  // The controlword 6040h was written (SDO, or an RPDO acting now / at SYNC).
  void on_controlword(DriveEmulator& emu) noexcept {
    switch (cia.on_controlword(static_cast<std::uint16_t>(u(s_cw)), quick_stop_option(),
                               estop_input(), fault_cause)) {
      case canopen::ControlwordEffect::kNone:
        return;
      case canopen::ControlwordEffect::kFaultResetRefused:
        ++counters.fault_resets_refused;
        return;
      case canopen::ControlwordEffect::kFaultReset:
        state_changed(emu);
        set(s_err, fw::emcy::kNoError);
        gone(emu, kFaultCondition);
        return;
      case canopen::ControlwordEffect::kTransition:
        state_changed(emu);
        return;
    }
  }

  // 6007h abort connection option (CiA 402-2): heartbeat loss, RPDO deadline, NMT events.
  void abort_connection(DriveEmulator& emu, std::uint16_t emcy_code) noexcept {
    switch (static_cast<fw::AbortConnectionOption>(i(s_abort))) {
      case fw::AbortConnectionOption::kNoAction:
        break;
      case fw::AbortConnectionOption::kFaultSignal:
        enter_fault(emu, emcy_code);
        break;
      case fw::AbortConnectionOption::kDisableVoltage:
        disable_voltage(emu);
        break;
      case fw::AbortConnectionOption::kQuickStop:
        if (cia.state() == Cia402State::kOperationEnabled)
          enter_quick_stop(emu);
        else if (cia.state() == Cia402State::kReadyToSwitchOn ||
                 cia.state() == Cia402State::kSwitchedOn)
          disable_voltage(emu);
        break;
    }
  }

  // ---- dictionary writes and their effects ----
  void after_write(DriveEmulator& emu, int slot, std::uint64_t now) noexcept {
    const OdEntry& e = dict.entry(slot);
    if (slot == s_cw) {
      on_controlword(emu);
    } else if (slot == s_mode) {
      set(s_mode_disp, u(s_mode));
      set(s_sw, statusword(estop_input()));
    } else if (slot == s_hb_prod) {
      nmt.producer_time_written(dict, now);
    } else if (e.index == fw::od::kConsumerHeartbeatCount.index) {
      hb_consumer.reset();
      for (int c = 0; c < kEmulatedConsumerHeartbeats; ++c) gone(emu, kHeartbeatLost + c, false);
    } else if (canopen::PdoEngine::is_parameter(e.index)) {
      pdos.rebuild_pdo_of(dict, e.index);
    }
  }

  // ---- live values (sampled at SYNC and before an SDO upload) ----
  void refresh(const DriveEmulator& emu) noexcept {
    const PlantOutput& out = emu.plant_.output();
    const std::int64_t counts =
        out.counts[static_cast<std::size_t>(index)] + cfg.zero_offset + encoder_offset;
    set(s_pos, static_cast<std::uint32_t>(counts));  // a 32-bit counter wraps
    const double cpr = static_cast<double>(cfg.counts_per_revolution);
    const double vel = out.q_dot.size() > index ? out.q_dot[index] * cpr / fw::kTwoPi : 0.0;
    set(s_vel, static_cast<std::uint32_t>(
                   fw::detail::round_saturate(vel, std::numeric_limits<std::int32_t>::min(),
                                              std::numeric_limits<std::int32_t>::max())));
    const double rated = fw::rated_torque_nm(u(s_rated));
    const double applied = out.tau_applied.size() > index ? out.tau_applied[index] : 0.0;
    set(s_torque, static_cast<std::uint16_t>(fw::nm_to_per_mille(applied, rated)));
    set(s_sw, statusword(estop_input()));
  }

  // ---- NMT ----
  void reset_communication_state(DriveEmulator& emu, std::uint64_t now) noexcept {
    pdos.rebuild(dict);
    sdo_server.reset();
    hb_consumer.reset();
    // The communication's error conditions end with it, silently (1001h keeps a fault).
    for (int c = kHeartbeatLost; c <= kWatchdog; ++c) gone(emu, c, false);
    wd_armed = false;
    wd_missed = 0;
    wd_tripped = false;
    torque_rx_since_sync = false;
    nmt.producer_time_written(dict, now);
  }
  // Power-on or reset node: the whole dictionary and the CiA 402 state machine restart.
  void reset_application(DriveEmulator& emu, std::uint64_t now) noexcept {
    dict.reset(0x0000, 0xFFFF);
    emcy.reset();
    set(s_din, hw_inputs);
    cia.power_on();
    state_changed(emu);
    reset_communication_state(emu, now);
  }
  void boot_up(DriveEmulator& emu, std::uint64_t now) noexcept {
    boot_pending = false;
    if (refuse_boot) {
      nmt.hold_in_initialisation();  // stays silent
      return;
    }
    Sink sink(*this, emu);
    nmt.boot_up(dict, now, sink);
  }
  void leave_operational(DriveEmulator& emu) noexcept {
    if (nmt_state() == EmulatedNmt::kOperational && cia.state() == Cia402State::kOperationEnabled)
      abort_connection(emu, fw::emcy::kCommunication);
    wd_armed = false;
    wd_missed = 0;
    pdos.stop();
  }
  // NMT (canopen::NmtSlave). The 6007h reaction to leaving Operational happens before the
  // state changes, so its EMCY still goes out.
  void on_nmt(DriveEmulator& emu, fw::NmtCommand c, std::uint64_t now) noexcept {
    if (nmt_state() == EmulatedNmt::kInitialisation) return;
    if (c == fw::NmtCommand::kStop || c == fw::NmtCommand::kEnterPreOperational ||
        c == fw::NmtCommand::kResetCommunication)
      leave_operational(emu);
    const canopen::NmtChange change = nmt.on_command(c);
    if (change.reset_application) {
      reset_application(emu, now);
      boot_up(emu, now);
    } else if (change.reset_communication) {
      dict.reset(0x1000, 0x1FFF);
      reset_communication_state(emu, now);
      boot_up(emu, now);
    }
  }

  // ---- SDO server (sim/canopen/sdo_server.hpp) ----
  // A download's value, checked and stored; kNoAbort on success.
  std::uint32_t download(DriveEmulator& emu, int slot, std::uint32_t v,
                         std::uint64_t now) noexcept {
    v &= mask_of(dict.entry(slot));
    if (const std::uint32_t a = check_write(slot, v); a != kNoAbort) return a;
    set(slot, v);
    after_write(emu, slot, now);
    return kNoAbort;
  }
  void on_sdo(DriveEmulator& emu, const fw::CanFrame& frame, std::uint64_t now) noexcept {
    ++counters.sdo_requests;
    // The drive behind the server: value checks and effects, live values before uploads.
    struct Hooks final : canopen::SdoServerHooks {
      Hooks(Drive& d, DriveEmulator& e, std::uint64_t t) noexcept : drive(d), emu(e), now(t) {}
      std::uint32_t download(int slot, std::uint32_t v) noexcept override {
        return drive.download(emu, slot, v, now);
      }
      void before_upload(int) noexcept override { drive.refresh(emu); }
      Drive& drive;
      DriveEmulator& emu;
      std::uint64_t now;
    } hooks(*this, emu, now);
    const std::uint64_t aborts = sdo_server.aborts_sent();
    fw::CanFrame response;
    if (sdo_server.on_request(frame, dict, hooks, response)) send(emu, response);
    counters.sdo_aborts_sent += sdo_server.aborts_sent() - aborts;
  }

  // ---- PDO engine (sim/canopen/pdo_engine.hpp) ----
  // The drive behind the engine: TPDOs out (or dropped by drop_tpdos), effects of RPDO writes.
  struct PdoAdapter final : canopen::PdoHooks {
    PdoAdapter(Drive& d, DriveEmulator& e) noexcept : drive(d), emu(e) {}
    void transmit(const fw::CanFrame& f) noexcept override {
      if (drive.drop_tpdos > 0) {
        if (drive.drop_tpdos != DriveEmulator::kForever) --drive.drop_tpdos;
        ++drive.counters.tpdos_dropped;
        return;
      }
      drive.send(emu, f);
      ++drive.counters.tpdos_sent;
    }
    void written(int slot, std::uint64_t now) noexcept override {
      drive.after_write(emu, slot, now);
    }
    void before_sample() noexcept override { drive.refresh(emu); }
    Drive& drive;
    DriveEmulator& emu;
  };
  // True when the frame was one of this drive's RPDOs.
  bool on_rpdo(DriveEmulator& emu, const fw::CanFrame& frame, std::uint64_t now) noexcept {
    PdoAdapter hooks(*this, emu);
    const canopen::RpdoReceipt r = pdos.on_rpdo(frame, nmt.pdo_allowed(), dict, hooks, now);
    if (r.too_short) {
      ++counters.rpdo_length_errors;
      // 8210h once per occurrence; the data is not used.
      if (!emcy.active(kPdoLength)) raise(emu, kPdoLength, fw::emcy::kPdoLengthError);
    }
    if (!r.accepted) return r.mine;
    ++counters.rpdos;
    gone(emu, kPdoLength);  // a correct RPDO: the condition is gone
    gone(emu, kDeadline);   // the RPDOs are back
    if (pdos.maps(PdoDirection::kRpdo, r.pdo, fw::od::kTargetTorque.index)) {
      torque_rx_since_sync = true;
      wd_armed = true;
    }
    return r.mine;
  }

  // ---- SYNC (see the timing in the header) ----
  void on_sync(DriveEmulator& emu, std::uint64_t now, bool real) noexcept {
    ++counters.syncs;
    if (nmt_state() == EmulatedNmt::kInitialisation) {
      torque_nm = 0.0;
      return;
    }
    refresh(emu);
    if (nmt_state() == EmulatedNmt::kOperational) {
      PdoAdapter hooks(*this, emu);
      if (real && !silent) pdos.transmit_at_sync(dict, hooks, now);
      pdos.latch_at_sync(dict, hooks, now);
      if (wd_armed && emu.config_.rpdo_watchdog_cycles > 0) {
        if (torque_rx_since_sync) {
          wd_missed = 0;
          if (wd_tripped) {
            wd_tripped = false;
            gone(emu, kWatchdog, !emcy.active(kDeadline));
          }
        } else if (++wd_missed >= emu.config_.rpdo_watchdog_cycles && !wd_tripped) {
          wd_tripped = true;
          raise(emu, kWatchdog, fw::emcy::kRpdoTimeout, false);  // the fault below reports it
          ++counters.watchdog_trips;
          if (cia.state() == Cia402State::kOperationEnabled)
            enter_fault(emu, fw::emcy::kRpdoTimeout);
        }
      }
      torque_rx_since_sync = false;
    }
    if (cia.state() == Cia402State::kQuickStopActive) {
      cia.on_sync();  // a quick stop with 605Ah 1..4 has "stopped" (12)
      state_changed(emu);
    }
    // Target torque -> N m, only in Operation enabled with mode 10 (CiA 402-2 CST).
    double tau = 0.0;
    limit_active = false;
    if (cia.state() == Cia402State::kOperationEnabled && mode_is_cst() && !estop_input() &&
        !wd_tripped) {
      const std::int32_t target = i(s_tt);
      const auto max = static_cast<std::int32_t>(u(s_max));
      const std::int32_t clipped = std::clamp(target, -max, max);
      limit_active = clipped != target;
      tau =
          fw::per_mille_to_nm(static_cast<std::int16_t>(clipped), fw::rated_torque_nm(u(s_rated)));
    }
    torque_nm = tau;
    emu.torque_[index] = tau;
    set(s_sw, statusword(estop_input()));
  }

  // ---- timers ----
  void on_time(DriveEmulator& emu, std::uint64_t now) noexcept {
    if (boot_pending && !refuse_boot) {
      reset_application(emu, now);
      boot_up(emu, now);
    }
    if (nmt_state() == EmulatedNmt::kInitialisation) return;
    // Heartbeat producer 1017h (canopen::NmtSlave).
    {
      Sink sink(*this, emu);
      if (nmt.on_time(dict, now, sink) && !silent) ++counters.heartbeats_sent;
    }
    // Heartbeat consumer 1016h: a silence of >= the consumer time is a heartbeat event.
    const unsigned lost = hb_consumer.on_time(dict, now);
    for (int c = 0; c < kEmulatedConsumerHeartbeats; ++c) {
      if ((lost & (1u << c)) == 0) continue;
      ++counters.heartbeat_losses;
      // With 6007h = fault signal the fault's own EMCY reports it.
      raise(emu, kHeartbeatLost + static_cast<int>(c), fw::emcy::kHeartbeatError,
            static_cast<fw::AbortConnectionOption>(i(s_abort)) !=
                fw::AbortConnectionOption::kFaultSignal);
      abort_connection(emu, fw::emcy::kHeartbeatError);
    }
    if (nmt_state() != EmulatedNmt::kOperational) return;
    // RPDO deadline monitoring: 1400h sub5 event timer (CiA 301 7.5.2.35).
    for (int expired = pdos.expired_deadlines(now); expired > 0; --expired) {
      ++counters.deadline_trips;
      raise(emu, kDeadline, fw::emcy::kRpdoTimeout,
            static_cast<fw::AbortConnectionOption>(i(s_abort)) !=
                fw::AbortConnectionOption::kFaultSignal);
      abort_connection(emu, fw::emcy::kRpdoTimeout);
    }
    // Event-driven TPDOs: a change held back by the inhibit time, and the event timer
    // (both bounded by the inhibit time).
    if (!silent) {
      PdoAdapter hooks(*this, emu);
      pdos.on_time(dict, hooks, now);
    }
  }

  // The earliest time at or after `now` at which on_time has something to do, mirroring
  // on_time above (kNever when nothing is scheduled): a caller may sleep until then.
  std::uint64_t next_due_ns(std::uint64_t now) const noexcept {
    if (boot_pending && !refuse_boot) return now;
    if (nmt_state() == EmulatedNmt::kInitialisation) return kNever;
    std::uint64_t due = kNever;
    due = std::min(due, nmt.next_due_ns(dict));
    due = std::min(due, hb_consumer.next_due_ns(dict));
    if (nmt_state() != EmulatedNmt::kOperational) return std::max(due, now);
    due = std::min(due, pdos.next_due_ns(now, !silent));
    return std::max(due, now);
  }

  void on_heartbeat(DriveEmulator& emu, const fw::Heartbeat& hb, std::uint64_t now) noexcept {
    const unsigned back = hb_consumer.on_heartbeat(dict, hb.node, now);
    for (int c = 0; c < kEmulatedConsumerHeartbeats; ++c)
      if ((back & (1u << c)) != 0) gone(emu, kHeartbeatLost + c);  // 0000h, what remains in 1001h
  }
};

// ---- DriveEmulator ---------------------------------------------------------------------

DriveEmulator::DriveEmulator(drivers::CanBus& bus, Plant& plant, const DriveEmulatorConfig& config)
    : bus_(bus), plant_(plant), config_(config) {
  config_.validate(plant.size());
  n_ = plant.size();
  torque_ = model::JointVector::Zero(n_);
  for (int k = 0; k < n_; ++k) {
    drives_[static_cast<std::size_t>(k)] = std::make_unique<Drive>();
    drives_[static_cast<std::size_t>(k)]->build(config_, k);
  }
}

DriveEmulator::~DriveEmulator() = default;

double DriveEmulator::period_s() const noexcept {
  // Nominal period for the free run and the SYNC monitoring: 1006h (us) as the master
  // wrote it on the first drive, else the configured period.
  const Drive& d = *drives_[0];
  const std::uint32_t us = d.u(d.s_period);
  return us != 0 ? static_cast<double>(us) * 1e-6
                 : static_cast<double>(config_.sync_period_ns) * 1e-9;
}

void DriveEmulator::command_plant() noexcept { plant_.command(torque_); }

void DriveEmulator::sync(std::uint64_t now_ns, bool real, std::uint64_t stamp_ns) noexcept {
  if (plant_started_) {
    // t_{k-1} -> t_k with the latched torque, by the SYNCs' actual spacing: receive
    // timestamps between two real SYNCs when the bus gives them, else handling times.
    const std::uint64_t dt_ns = (real && last_advance_real_ && stamp_ns != 0 &&
                                 last_sync_stamp_ns_ != 0 && stamp_ns > last_sync_stamp_ns_)
                                    ? stamp_ns - last_sync_stamp_ns_
                                    : now_ns - last_advance_ns_;
    if (real) {
      const Drive& d = *drives_[0];
      const std::uint64_t nominal_ns = static_cast<std::uint64_t>(d.u(d.s_period)) * 1000u;
      if (nominal_ns != 0 && dt_ns > nominal_ns + nominal_ns / 2) ++late_syncs_;
    }
    const std::uint64_t step_ns = real && config_.plant_step_nominal
                                      ? static_cast<std::uint64_t>(period_s() * 1e9 + 0.5)
                                      : dt_ns;
    if (step_ns > 0) plant_.advance(static_cast<double>(step_ns) * 1e-9);
  }
  plant_started_ = true;
  last_advance_ns_ = now_ns;
  last_advance_real_ = real;
  if (real) {
    ++syncs_;
    last_real_sync_ns_ = now_ns;
    last_sync_stamp_ns_ = stamp_ns;
  } else {
    ++virtual_syncs_;
  }
  for (int k = 0; k < n_; ++k) drives_[static_cast<std::size_t>(k)]->on_sync(*this, now_ns, real);
  command_plant();  // acts from t_k to t_{k+1}
}

std::size_t DriveEmulator::poll(std::uint64_t now_ns) noexcept {
  std::size_t received = 0;
  fw::CanFrame frame;
  // Bounded: a flood cannot keep the caller here forever.
  while (received < 4096 && bus_.receive(frame) == drivers::BusStatus::kOk) {
    on_frame(frame, now_ns);
    ++received;
  }
  on_time(now_ns);
  return received;
}

void DriveEmulator::on_frame(const fw::CanFrame& frame, std::uint64_t now_ns) noexcept {
  if (!powered_) on_time(now_ns);  // power on first: a frame never reaches an unbooted dictionary
  last_frame_ns_ = now_ns;
  if (frame.extended || frame.rtr) {
    ++unhandled_frames_;
    return;
  }
  if (frame.id == fw::kNmtCobId) {
    const fw::Result<fw::NmtMessage> m = fw::decode_nmt(frame);
    if (!m) {
      ++unhandled_frames_;
      return;
    }
    for (int k = 0; k < n_; ++k) {
      Drive& d = *drives_[static_cast<std::size_t>(k)];
      if (!d.silent && fw::addressed_to(*m, d.node)) d.on_nmt(*this, m->command, now_ns);
    }
    return;
  }
  const Drive& first = *drives_[0];
  if (frame.id == (first.u(first.s_sync) & fw::kMaxStandardId)) {
    if (!fw::decode_sync(frame)) {
      ++unhandled_frames_;
      return;
    }
    free_running_ = false;
    sync(now_ns, true, frame.timestamp_ns);
    return;
  }
  bool handled = false;
  const fw::Result<fw::CobIdInfo> info = fw::classify(frame);
  for (int k = 0; k < n_; ++k) {
    Drive& d = *drives_[static_cast<std::size_t>(k)];
    if (d.silent || d.nmt_state() == EmulatedNmt::kInitialisation) continue;
    if (info && info->function == fw::Function::kSdoRx && info->node == d.node) {
      handled = true;
      if (d.nmt.sdo_allowed()) d.on_sdo(*this, frame, now_ns);
      continue;
    }
    if (info && info->function == fw::Function::kHeartbeat) {
      const fw::Result<fw::Heartbeat> hb = fw::decode_heartbeat(frame);
      if (hb) {
        d.on_heartbeat(*this, *hb, now_ns);
        handled = true;
      }
      continue;
    }
    handled = d.on_rpdo(*this, frame, now_ns) || handled;
  }
  if (!handled) ++unhandled_frames_;
}

void DriveEmulator::on_time(std::uint64_t now_ns) noexcept {
  if (!powered_) {
    powered_ = true;
    for (int k = 0; k < n_; ++k) drives_[static_cast<std::size_t>(k)]->boot_pending = true;
  }
  for (int k = 0; k < n_; ++k) drives_[static_cast<std::size_t>(k)]->on_time(*this, now_ns);
  // Free run of the plant when SYNCs have stopped (a dead master).
  if (!plant_started_ || config_.free_run_after_ns == 0) return;
  const auto p = static_cast<std::uint64_t>(std::llround(period_s() * 1e9));
  if (p == 0) return;
  if (!free_running_ && now_ns - last_advance_ns_ >= config_.free_run_after_ns)
    free_running_ = true;
  for (int guard = 0; free_running_ && now_ns - last_advance_ns_ >= p && guard < 100'000; ++guard)
    sync(last_advance_ns_ + p, false);
}

std::uint64_t DriveEmulator::next_due_ns(std::uint64_t now_ns) const noexcept {
  if (!powered_) return now_ns;
  std::uint64_t due = kNever;
  for (int k = 0; k < n_; ++k)
    due = std::min(due, drives_[static_cast<std::size_t>(k)]->next_due_ns(now_ns));
  if (plant_started_ && config_.free_run_after_ns != 0) {
    const auto p = static_cast<std::uint64_t>(std::llround(period_s() * 1e9));
    if (p != 0)
      due = std::min(due, last_advance_ns_ + (free_running_ ? p : config_.free_run_after_ns));
  }
  return std::max(due, now_ns);
}

void DriveEmulator::press_estop(bool pressed) noexcept {
  estop_ = pressed;
  for (int k = 0; k < n_; ++k) set_digital_inputs(k, fw::od::kDigitalInputEstopMask, pressed);
}

void DriveEmulator::set_digital_inputs(int drive, std::uint32_t mask, bool on) noexcept {
  if (drive < 0 || drive >= n_) return;
  Drive& d = *drives_[static_cast<std::size_t>(drive)];
  d.hw_inputs = on ? (d.hw_inputs | mask) : (d.hw_inputs & ~mask);
  d.set(d.s_din, d.hw_inputs);
  if (d.estop_input()) {
    // STO: the power stage is off whatever the controlword says.
    d.disable_voltage(*this);  // from Ready to switch on .. Quick stop active
  }
  d.set(d.s_sw, d.statusword(d.estop_input()));
}

void DriveEmulator::inject_fault(int drive, std::uint16_t emcy_code) noexcept {
  if (drive < 0 || drive >= n_) return;
  drives_[static_cast<std::size_t>(drive)]->enter_fault(*this, emcy_code);
}

void DriveEmulator::hold_fault(int drive, std::uint16_t emcy_code) noexcept {
  if (drive < 0 || drive >= n_) return;
  Drive& d = *drives_[static_cast<std::size_t>(drive)];
  d.fault_cause = true;
  d.enter_fault(*this, emcy_code);
}

void DriveEmulator::release_fault(int drive) noexcept {
  if (drive >= 0 && drive < n_) drives_[static_cast<std::size_t>(drive)]->fault_cause = false;
}

void DriveEmulator::set_silent(int drive, bool silent) noexcept {
  if (drive >= 0 && drive < n_) drives_[static_cast<std::size_t>(drive)]->silent = silent;
}

void DriveEmulator::set_refuse_boot(int drive, bool refuse) noexcept {
  if (drive < 0 || drive >= n_) return;
  Drive& d = *drives_[static_cast<std::size_t>(drive)];
  d.refuse_boot = refuse;
  if (!refuse && d.nmt_state() == EmulatedNmt::kInitialisation && powered_) d.boot_pending = true;
}

void DriveEmulator::drop_tpdos(int drive, std::uint32_t n) noexcept {
  if (drive >= 0 && drive < n_) drives_[static_cast<std::size_t>(drive)]->drop_tpdos = n;
}

void DriveEmulator::inject_encoder_offset(int drive, std::int32_t counts) noexcept {
  if (drive >= 0 && drive < n_) drives_[static_cast<std::size_t>(drive)]->encoder_offset += counts;
}

const canopen::ObjectDictionary& DriveEmulator::dictionary(int drive) const noexcept {
  return drives_[static_cast<std::size_t>(drive)]->dict;
}

EmulatedDriveStatus DriveEmulator::status(int drive) const noexcept {
  EmulatedDriveStatus s;
  if (drive < 0 || drive >= n_) return s;
  const Drive& d = *drives_[static_cast<std::size_t>(drive)];
  s.node_id = d.node;
  s.nmt = d.nmt_state();
  s.state = d.cia.state();
  s.last_transition = d.cia.last_transition();
  s.statusword = static_cast<std::uint16_t>(d.u(d.s_sw));
  s.controlword = static_cast<std::uint16_t>(d.u(d.s_cw));
  s.target_torque = static_cast<std::int16_t>(d.i(d.s_tt));
  s.torque_nm = d.torque_nm;
  s.position = d.i(d.s_pos);
  s.error_code = static_cast<std::uint16_t>(d.u(d.s_err));
  s.error_register = static_cast<std::uint8_t>(d.u(d.s_err_reg));
  s.digital_inputs = d.u(d.s_din);
  s.watchdog_missed = d.wd_missed;
  s.heartbeat_lost = d.hb_consumer.any_lost();
  s.silent = d.silent;
  s.counters = d.counters;
  s.counters.emcy_sent = d.emcy.sent();
  return s;
}

bool DriveEmulator::read_object(int drive, std::uint16_t index, std::uint8_t subindex,
                                std::uint32_t& raw) const noexcept {
  if (drive < 0 || drive >= n_) return false;
  const Drive& d = *drives_[static_cast<std::size_t>(drive)];
  const int slot = d.find(index, subindex);
  if (slot < 0) return false;
  raw = d.u(slot);
  return true;
}

}  // namespace dualv::sim
