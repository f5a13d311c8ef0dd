#include "drivers/canopen_actuator_set.hpp"

#include <fmt/format.h>

#include "common/config_error.hpp"
#include "drivers/canopen/boot.hpp"
#include "firmware_if/byte_order.hpp"
#include "firmware_if/cob_id.hpp"
#include "firmware_if/emcy.hpp"
#include "firmware_if/heartbeat.hpp"
#include "firmware_if/pdo.hpp"
#include "firmware_if/sync.hpp"
#include "firmware_if/units.hpp"

namespace dualv::drivers {

const char* to_string(DriveHealth h) noexcept {
  switch (h) {
    case DriveHealth::kOk:
      return "OK";
    case DriveHealth::kWarn:
      return "WARN";
    case DriveHealth::kError:
      return "ERROR";
    case DriveHealth::kStale:
      return "STALE";
  }
  return "?";
}

std::string describe(const DriveHealthReport& h) {
  std::string s = fmt::format("node {}: {} ({}) NMT {}, CiA 402 {}", h.node, to_string(h.health),
                              h.reason, h.nmt_known ? fw::to_string(h.nmt_state) : "unknown",
                              h.cia402_known ? fw::to_string(h.cia402_state) : "unknown");
  if (h.last_emcy_code != 0)
    s += fmt::format(", EMCY {:04X}h {} ({})", h.last_emcy_code,
                     h.emcy_active ? "active" : "cleared", h.last_emcy_text);
  if (h.own_stop != StopCause::kNone) s += fmt::format(", own stop: {}", to_string(h.own_stop));
  if (h.transition_timed_out) s += ", CiA 402 transition timed out";
  if (h.stop_input) s += ", e-stop input active";
  s += fmt::format(", last TPDO {} cycles ago", h.cycles_since_fresh);
  return s;
}

namespace {
constexpr std::uint32_t bit(int i) noexcept { return 1u << static_cast<unsigned>(i); }

const CanConfig& checked(const CanConfig& c) {
  validate(c);
  (void)require_bus_load_fits(c);
  return c;
}
}  // namespace

CanopenActuatorSet::CanopenActuatorSet(CanBus& bus, const canopen::Clock& clock,
                                       const CanConfig& config)
    : bus_(bus),
      clock_(clock),
      config_(checked(config)),
      n_(config.size()),
      bus_load_(bus_load_report(config)),
      sync_(config.sync_counter_overflow),
      heartbeat_producer_(config.master_node_id, config.master_heartbeat_period_ns) {
  drive_of_node_.fill(-1);
  // The drive sends its statusword at least every can.statusword_refresh (event timer), a
  // change at most can.statusword_inhibit late: beyond refresh + stale_cycles it is lost.
  statusword_bound_cycles_ = static_cast<std::uint32_t>(
      (config_.statusword_refresh_ns + config_.sync_period_ns - 1) / config_.sync_period_ns +
      config_.stale_cycles);
  const std::uint64_t now = clock_.now_ns();
  for (int i = 0; i < n_; ++i) {
    const CanDriveConfig& d = config_.drives[static_cast<std::size_t>(i)];
    drive_of_node_[d.node_id] = static_cast<std::int8_t>(i);
    drives_[i].set_transition_timeout(config_.transition_timeout_ns);
    heartbeats_[i] = canopen::HeartbeatConsumer(d.node_id, config_.drive_heartbeat_timeout_ns);
    heartbeats_[i].arm(now);
  }
}

bool CanopenActuatorSet::operational(int i) const noexcept {
  const canopen::HeartbeatConsumer& h = heartbeats_[i];
  // Before the first heartbeat the boot sequence vouches for the node (it saw Operational).
  return !h.timed_out() && (!h.seen() || h.state() == fw::NmtState::kOperational);
}

void CanopenActuatorSet::lose(int i) noexcept {
  const bool was_enabled = drives_[i].goal() == Cia402Goal::kOperationEnabled;
  drives_[i].on_lost();
  if (was_enabled) events_.own_stop |= bit(i);
}

void CanopenActuatorSet::latch_bus_off() noexcept {
  if (bus_off_) return;
  bus_off_ = true;
  ++counters_.bus_off;
  events_.bus_off = true;
  write_events_.bus_off = true;
  for (int i = 0; i < n_; ++i) lose(i);
}

BusStatus CanopenActuatorSet::send(const fw::CanFrame& f) noexcept {
  const BusStatus s = bus_.send(f);
  switch (s) {
    case BusStatus::kOk:
      break;
    case BusStatus::kWouldBlock:
      ++counters_.tx_would_block;  // ENOBUFS: dropped here, never queued for later
      break;
    case BusStatus::kBusOff:
      latch_bus_off();
      break;
    default:
      ++counters_.tx_errors;
      break;
  }
  return s;
}

void CanopenActuatorSet::on_tpdo(int i, const fw::CanFrame& f) noexcept {
  DriveCounters& c = drive_counters_[i];
  fw::Result<fw::DriveFeedback> fb = fw::Error::kWrongDlc;
  if (config_.bus_layout != fw::BusLayout::kBroadcast) {  // per_drive, fd (an FD frame)
    fb = fw::decode_tpdo1(f);
  } else {  // position alone; the statusword comes in TPDO3 (on_statusword_tpdo)
    const fw::Result<std::int32_t> pos = fw::decode_position_tpdo(f);
    if (pos) fb = fw::DriveFeedback{statusword_[i], *pos};
  }
  if (!fb) {
    ++c.malformed;
    return;
  }
  if (f.timestamp_ns != 0 && tpdo_stamp_[i] != 0 && f.timestamp_ns < tpdo_stamp_[i]) {
    ++c.out_of_order;  // older than what we already have: never let it overwrite
    return;
  }
  if (tpdos_this_cycle_[i] > 0) {
    if (fb->statusword == statusword_[i] && fb->position == position_[i]) {
      ++c.duplicates;
      return;
    }
    ++c.late;  // the older one answered an earlier SYNC; the newest wins
  }
  ++tpdos_this_cycle_[i];
  ++c.tpdos;
  statusword_[i] = fb->statusword;
  position_[i] = fb->position;
  if (f.timestamp_ns != 0) tpdo_stamp_[i] = f.timestamp_ns;
}

void CanopenActuatorSet::on_statusword_tpdo(int i, const fw::CanFrame& f) noexcept {
  const fw::Result<std::uint16_t> sw = fw::decode_statusword_tpdo(f);
  if (!sw) {
    ++drive_counters_[i].malformed;
    return;
  }
  ++drive_counters_[i].statuswords;
  statusword_[i] = *sw;
  statusword_seen_[i] = true;
  cycles_since_statusword_[i] = 0;
}

bool CanopenActuatorSet::statusword_current(int i) const noexcept {
  if (config_.bus_layout != fw::BusLayout::kBroadcast) return true;  // in every TPDO1
  return statusword_seen_[i] && cycles_since_statusword_[i] <= statusword_bound_cycles_;
}

void CanopenActuatorSet::dispatch(const fw::CanFrame& f, std::uint64_t now) noexcept {
  const fw::Result<fw::CobIdInfo> info = fw::classify(f);
  if (!info) {
    ++counters_.unknown_frames;
    return;
  }
  const int i = info->node <= fw::kMaxNodeId ? drive_of_node_[info->node] : -1;
  switch (info->function) {
    case fw::Function::kTpdo1:
      if (i < 0) break;
      on_tpdo(i, f);
      return;
    case fw::Function::kTpdo3:
      // The statusword TPDO of the broadcast layout; another TPDO3 is not ours.
      if (i < 0 || config_.bus_layout != fw::BusLayout::kBroadcast) break;
      on_statusword_tpdo(i, f);
      return;
    case fw::Function::kTpdo2: {
      // 60FDh digital inputs (event driven): the e-stop circuit, as the drive sees it.
      if (i < 0) break;
      if (f.dlc != canopen::kDigitalInputsTpdoLayout.bytes() || f.rtr) {
        ++drive_counters_[i].malformed;
        return;
      }
      const std::uint32_t di = fw::get_u32_le(f.data.data());
      const bool was = (digital_inputs_[i] & fw::od::kDigitalInputEstopMask) != 0;
      if (!was && (di & fw::od::kDigitalInputEstopMask) != 0) events_.stop_input |= bit(i);
      digital_inputs_[i] = di;
      return;
    }
    case fw::Function::kHeartbeat: {
      if (i < 0) break;
      const fw::Result<fw::Heartbeat> hb = fw::decode_heartbeat(f);
      if (!hb) {
        ++counters_.malformed_frames;
        return;
      }
      const canopen::HeartbeatEvent e = heartbeats_[i].on_heartbeat(hb->state, now);
      if (e == canopen::HeartbeatEvent::kBootUp) {
        // The node reset itself: its configuration is gone, it is not ours any more.
        ++drive_counters_[i].boot_ups;
        events_.boot_up |= bit(i);
        lose(i);
      } else if (hb->state != fw::NmtState::kOperational) {
        if (e != canopen::HeartbeatEvent::kNone) events_.nmt_not_operational |= bit(i);
        lose(i);
      }
      return;
    }
    case fw::Function::kEmcy: {
      if (i < 0) break;
      const fw::Result<fw::Emcy> e = fw::decode_emcy(f);
      if (!e) {
        ++counters_.malformed_frames;
        return;
      }
      ++drive_counters_[i].emcys;
      if (emcys_[i].on_emcy(*e, now))
        events_.emcy_raised |= bit(i);
      else
        events_.emcy_cleared |= bit(i);
      return;
    }
    case fw::Function::kSync: {
      // We are the SYNC producer: another one on the bus is a configuration error.
      ++counters_.foreign_sync;
      const fw::Result<fw::Sync> s = fw::decode_sync(f);
      if (!s) {
        ++counters_.malformed_frames;
        return;
      }
      if (s->counter != 0 && foreign_sync_counter_ != 0 &&
          s->counter != fw::next_sync_counter(foreign_sync_counter_, fw::kSyncCounterOverflowMax) &&
          !(s->counter == fw::kSyncCounterMin &&
            foreign_sync_counter_ >= fw::kSyncCounterOverflowMin))
        ++counters_.sync_counter_jumps;
      foreign_sync_counter_ = s->counter;
      return;
    }
    default:
      ++counters_.ignored_frames;  // SDO, NMT, RPDOs, other PDOs
      return;
  }
  ++counters_.unknown_frames;  // a node that is not ours
}

IoStatus CanopenActuatorSet::read(ActuatorFeedback& fb) noexcept {
  const std::uint64_t now = clock_.now_ns();
  cycle_now_ns_ = now;  // write() of this cycle uses it: one clock read per cycle
  events_ = write_events_;
  write_events_ = CycleEvents{};
  tpdos_this_cycle_.fill(0);

  if (!bus_off_ && bus_.state() == BusStatus::kBusOff) latch_bus_off();
  if (!bus_off_) {
    // Every pending frame, a batch at a time (one syscall per batch on SocketCAN).
    std::array<fw::CanFrame, 16> frames;
    for (;;) {
      BusStatus s = BusStatus::kOk;
      const std::size_t got = bus_.receive_many(frames, s);
      for (std::size_t k = 0; k < got; ++k) dispatch(frames[k], now);
      if (s == BusStatus::kOk) continue;
      if (s == BusStatus::kBusOff) latch_bus_off();
      break;
    }
  }

  bool all_fresh = true;
  bool all_seen = true;
  for (int i = 0; i < n_; ++i) {
    if (heartbeats_[i].check(now) == canopen::HeartbeatEvent::kTimeout) {
      ++drive_counters_[i].heartbeat_timeouts;
      events_.heartbeat_lost |= bit(i);
      lose(i);
    }
    fresh_[i] = tpdos_this_cycle_[i] > 0 && !bus_off_ && statusword_current(i);
    if (fresh_[i]) {
      cycles_since_fresh_[i] = 0;
      ever_fresh_[i] = true;
      const std::uint64_t stops = drives_[i].own_stops();
      const std::uint64_t timeouts = drives_[i].transition_timeouts();
      if (operational(i)) drives_[i].on_statusword(statusword_[i], now);
      if (drives_[i].own_stops() != stops) events_.own_stop |= bit(i);
      if (drives_[i].transition_timeouts() != timeouts) events_.transition_timeout |= bit(i);
    } else {
      if (cycles_since_fresh_[i] < 0xFFFFFFFFu) ++cycles_since_fresh_[i];
      if (sync_sent_last_cycle_) ++drive_counters_[i].missed;
      events_.stale |= bit(i);
    }
    all_fresh = all_fresh && fresh_[i];
    all_seen = all_seen && ever_fresh_[i];

    DriveFeedback& d = fb.drive[i];
    const CanDriveConfig& dc = config_.drives[static_cast<std::size_t>(i)];
    d.state = (operational(i) && !bus_off_) ? drives_[i].drive_state() : DriveState::kOffline;
    d.position = fw::counts_to_rad(position_[i] - dc.zero_offset, dc.counts_per_revolution);
    d.fresh = fresh_[i];
    d.statusword = statusword_[i];
    d.last_emcy = emcys_[i].active_code();
    d.stop_input = (digital_inputs_[i] & fw::od::kDigitalInputEstopMask) != 0;
    d.torque_actual = torque_applied_[i];
  }
  sync_sent_last_cycle_ = false;  // a SYNC's answers are expected (and missed) once
  for (int i = 0; i < n_; ++i)
    if (cycles_since_statusword_[i] < 0xFFFFFFFFu) ++cycles_since_statusword_[i];
  fb.n = n_;
  fb.cycle = cycle_;
  if (bus_off_) return IoStatus::kBusError;
  if (!all_seen) return IoStatus::kNotReady;
  return all_fresh ? IoStatus::kOk : IoStatus::kStale;
}

IoStatus CanopenActuatorSet::write(const ActuatorCommand& command) noexcept {
  // The time read() took for this cycle (the cycle's time, tens of microseconds earlier), or
  // the clock's when write() comes without read() (priming, shutdown).
  const std::uint64_t now = cycle_now_ns_ != 0 ? cycle_now_ns_ : clock_.now_ns();
  cycle_now_ns_ = 0;
  ++cycle_;
  ++counters_.cycles;
  const bool shape_ok = command.n == n_;
  // A malformed command is treated as a disable request with zero torque.
  const DriveRequest request = shape_ok ? command.request : DriveRequest::kDisable;
  sync_sent_last_cycle_ = false;
  if (bus_off_) {
    for (int i = 0; i < n_; ++i) sent_[i].sent = false;
    return IoStatus::kBusError;
  }

  bool ok = shape_ok;
  std::array<std::int16_t, kMaxDrives> torque{};
  for (int i = 0; i < n_; ++i) {
    const std::uint64_t stops = drives_[i].own_stops();
    const std::uint64_t timeouts = drives_[i].transition_timeouts();
    const Cia402Output out = drives_[i].update(operational(i) ? request : DriveRequest::kHold, now);
    if (drives_[i].own_stops() != stops) write_events_.own_stop |= bit(i);
    if (drives_[i].transition_timeouts() != timeouts) write_events_.transition_timeout |= bit(i);
    const CanDriveConfig& dc = config_.drives[static_cast<std::size_t>(i)];
    // A statusword older than can.timeouts.stale_cycles cannot vouch for Operation enabled.
    const bool recent = ever_fresh_[i] && cycles_since_fresh_[i] < config_.stale_cycles;
    torque[i] = (out.torque_allowed && shape_ok && recent)
                    ? fw::nm_to_per_mille(command.torque[i], dc.rated_torque)
                    : std::int16_t{0};
    sent_[i].controlword = out.controlword;
    sent_[i].torque_per_mille = torque[i];
    sent_[i].sent = false;
  }
  events_.own_stop |= write_events_.own_stop;
  events_.transition_timeout |= write_events_.transition_timeout;

  // The cycle's frames, sent in one batch (one syscall on SocketCAN): the RPDOs (or the
  // controlwords due and the broadcast torques, or the one FD frame), the SYNC, the heartbeat
  // when due.
  enum class Tx : std::uint8_t { kRpdo, kControlword, kBroadcast, kSync, kHeartbeat };
  struct Pending {
    Tx what;
    int drive;
  };
  constexpr std::size_t kMaxFrames = 2 * kMaxDrives + 3;
  std::array<fw::CanFrame, kMaxFrames> frames{};
  std::array<Pending, kMaxFrames> pending{};
  std::size_t count = 0;
  auto add = [&](const fw::Result<fw::CanFrame>& f, Tx what, int drive) {
    if (!f) {  // cannot happen with a validated configuration; counted, never sent
      ++counters_.tx_errors;
      return;
    }
    frames[count] = *f;
    pending[count++] = {what, drive};
  };
  const bool per_drive = config_.bus_layout == fw::BusLayout::kPerDrive;
  const bool fd = config_.bus_layout == fw::BusLayout::kFd;
  if (per_drive) {
    for (int i = 0; i < n_; ++i)
      add(fw::encode_rpdo1(config_.drives[static_cast<std::size_t>(i)].node_id,
                           {sent_[i].controlword, torque[i]}),
          Tx::kRpdo, i);
  } else if (fd) {
    // One CAN FD frame with every drive's controlword + torque (firmware_if/pdo.hpp).
    fw::FdCommands c;
    c.drives = static_cast<std::uint8_t>(n_);
    for (int i = 0; i < n_; ++i) c.command[i] = {sent_[i].controlword, torque[i]};
    add(fw::encode_fd_commands(c), Tx::kBroadcast, 0);
  } else {
    for (int i = 0; i < n_; ++i) {
      // On change, at most once per can.controlword_inhibit (a change waits it out, the
      // torque in the broadcast frame is already what the new state allows); at least once
      // per can.controlword_refresh.
      const bool changed = !controlword_ok_[i] || sent_[i].controlword != last_controlword_[i];
      const bool inhibited =
          controlword_ok_[i] &&
          !canopen::expired(controlword_sent_ns_[i], now, config_.controlword_inhibit_ns);
      if (inhibited) sent_[i].controlword = last_controlword_[i];  // what the wire carries
      if (!inhibited && (changed || canopen::expired(controlword_sent_ns_[i], now,
                                                     config_.controlword_refresh_ns)))
        add(fw::encode_controlword_rpdo(config_.drives[static_cast<std::size_t>(i)].node_id,
                                        sent_[i].controlword),
            Tx::kControlword, i);
    }
    fw::BroadcastTorques t;
    t.drives = static_cast<std::uint8_t>(n_);
    for (int i = 0; i < n_; ++i) t.torque[i] = torque[i];
    add(fw::encode_broadcast_torques(t), Tx::kBroadcast, 0);
  }
  const std::size_t sync_at = count;
  add(sync_.next_frame(), Tx::kSync, 0);
  if (sync_at == count) ok = false;
  if (heartbeat_producer_.due(now))
    add(fw::encode_heartbeat(heartbeat_producer_.node(), fw::NmtState::kOperational),
        Tx::kHeartbeat, 0);

  // Every frame is tried once, as if sent one by one: a frame the bus refuses (ENOBUFS) is
  // dropped and the next is tried; after bus-off nothing more is tried (kClosed).
  std::array<BusStatus, kMaxFrames> outcome{};
  outcome.fill(BusStatus::kClosed);
  for (std::size_t k = 0; k < count;) {
    BusStatus st = BusStatus::kOk;
    const std::size_t sent = bus_.send_many(std::span(frames).subspan(k, count - k), st);
    for (std::size_t j = k; j < k + sent; ++j) outcome[j] = BusStatus::kOk;
    k += sent;
    if (k == count) break;
    outcome[k++] = st;
    if (st == BusStatus::kWouldBlock)
      ++counters_.tx_would_block;  // dropped, never queued
    else if (st == BusStatus::kBusOff)
      break;
    else
      ++counters_.tx_errors;
  }
  bool broadcast_sent = per_drive;
  for (std::size_t k = 0; k < count; ++k) {
    const bool sent = outcome[k] == BusStatus::kOk;
    if (outcome[k] == BusStatus::kBusOff) latch_bus_off();
    const int i = pending[k].drive;
    switch (pending[k].what) {
      case Tx::kRpdo:
        sent_[i].sent = sent;
        ok = ok && sent;
        break;
      case Tx::kControlword:
        if (sent) {
          controlword_sent_ns_[i] = now;
          last_controlword_[i] = sent_[i].controlword;
        }
        controlword_ok_[i] = sent;
        ok = ok && sent;
        break;
      case Tx::kBroadcast:
        broadcast_sent = sent;
        ok = ok && sent;
        break;
      case Tx::kSync:
        if (outcome[k] != BusStatus::kClosed) sync_.on_sent(outcome[k]);
        if (sent) {
          ++counters_.sync_sent;
          sync_sent_last_cycle_ = true;
        } else {
          ok = false;
        }
        break;
      case Tx::kHeartbeat:
        if (outcome[k] != BusStatus::kClosed) heartbeat_producer_.on_sent(outcome[k], now);
        if (sent) ++counters_.heartbeats_sent;
        break;
    }
  }
  if (fd)  // the one frame carries every controlword and torque
    for (int i = 0; i < n_; ++i) sent_[i].sent = broadcast_sent;
  else if (!per_drive)
    for (int i = 0; i < n_; ++i) sent_[i].sent = broadcast_sent && controlword_ok_[i];
  for (int i = 0; i < n_; ++i)
    torque_applied_[i] =
        sent_[i].sent ? fw::per_mille_to_nm(
                            torque[i], config_.drives[static_cast<std::size_t>(i)].rated_torque)
                      : 0.0;
  if (bus_off_) return IoStatus::kBusError;
  return ok ? IoStatus::kOk : IoStatus::kBusError;
}

BusStatus CanopenActuatorSet::recover_bus() noexcept {
  if (!bus_off_) return BusStatus::kOk;
  const BusStatus s = bus_.restart();
  if (s != BusStatus::kOk) return s;
  bus_off_ = false;
  ++counters_.recoveries;
  for (int i = 0; i < n_; ++i) {
    drives_[i].on_lost();  // disabled; a new kEnable is needed
    tpdo_stamp_[i] = 0;
    heartbeats_[i].arm(clock_.now_ns());
  }
  return BusStatus::kOk;
}

std::uint32_t CanopenActuatorSet::prime(canopen::Waiter& waiter, std::uint64_t timeout_ns) {
  const std::uint64_t deadline = clock_.now_ns() + timeout_ns;
  ActuatorFeedback fb;
  ActuatorCommand hold;
  hold.n = n_;
  hold.request = DriveRequest::kHold;
  for (;;) {
    (void)write(hold);
    const std::uint64_t next = clock_.now_ns() + config_.sync_period_ns;
    while (clock_.now_ns() < next) waiter.wait_until(next);
    (void)read(fb);
    std::uint32_t missing = 0;
    for (int i = 0; i < n_; ++i)
      if (!ever_fresh_[i]) missing |= bit(i);
    if (missing == 0 || clock_.now_ns() >= deadline) return missing;
  }
}

bool CanopenActuatorSet::shut_down(canopen::Waiter& waiter,
                                   const std::function<void(const std::string&)>& log, int cycles) {
  auto say = [&log](const std::string& line) {
    if (log) log(line);
  };
  if (bus_off_) {
    say("shutdown: CAN bus-off, nothing can be sent; the drives react to the silence (6007h)");
    return false;
  }
  ActuatorFeedback fb;
  ActuatorCommand off;
  off.n = n_;
  off.request = DriveRequest::kDisable;  // torque 0: torque_allowed is false when disabling
  cycles = std::max(cycles, 1);
  for (int k = 0; k < cycles; ++k) {
    (void)write(off);
    const std::uint64_t next = clock_.now_ns() + config_.sync_period_ns;
    while (clock_.now_ns() < next) waiter.wait_until(next);
    (void)read(fb);
  }
  bool all_disabled = true;
  std::string states;
  for (int i = 0; i < n_; ++i) {
    const Cia402Drive& d = drives_[i];
    const bool disabled = d.known() && d.state() != fw::Cia402State::kOperationEnabled &&
                          d.state() != fw::Cia402State::kQuickStopActive;
    all_disabled = all_disabled && disabled;
    states += fmt::format("{}node {}: {}", states.empty() ? "" : ", ",
                          config_.drives[static_cast<std::size_t>(i)].node_id,
                          d.known() ? fw::to_string(d.state()) : "no statusword");
  }
  say(
      fmt::format("shutdown: target torque 0 and disable voltage (controlword {:04X}h) for {} "
                  "SYNC cycles: {}",
                  fw::apply(fw::Command::kDisableVoltage, 0), cycles, states));
  fw::NmtCommand nmt = fw::NmtCommand::kEnterPreOperational;
  switch (config_.on_exit) {
    case OnExit::kPreOperational:
      nmt = fw::NmtCommand::kEnterPreOperational;
      break;
    case OnExit::kStopped:
      nmt = fw::NmtCommand::kStop;
      break;
    case OnExit::kOperationalDisabled:
      say("shutdown: drives left NMT Operational with the voltage disabled (can.on_exit: "
          "operational_disabled)");
      return all_disabled;
  }
  std::string sent;
  for (int i = 0; i < n_; ++i) {
    const std::uint8_t id = config_.drives[static_cast<std::size_t>(i)].node_id;
    const fw::Result<fw::CanFrame> f = fw::encode_nmt(nmt, id);
    const bool ok = f && send(*f) == BusStatus::kOk;
    sent += fmt::format("{}{}{}", sent.empty() ? "" : ", ", id, ok ? "" : " (send failed)");
  }
  say(fmt::format("shutdown: NMT {} sent to node{} {} (can.on_exit: {})", fw::to_string(nmt),
                  n_ > 1 ? "s" : "", sent, to_string(config_.on_exit)));
  return all_disabled;
}

void CanopenActuatorSet::service() noexcept {
  const std::uint64_t now = clock_.now_ns();
  if (bus_off_) return;
  fw::CanFrame f;
  while (bus_.receive(f) == BusStatus::kOk) dispatch(f, now);
  const std::uint64_t before = heartbeat_producer_.sent();
  (void)heartbeat_producer_.poll(bus_, now);
  counters_.heartbeats_sent += heartbeat_producer_.sent() - before;
}

DriveHealthReport CanopenActuatorSet::health(int i) const noexcept {
  DriveHealthReport r;
  if (i < 0 || i >= n_) return r;
  const canopen::HeartbeatConsumer& hb = heartbeats_[i];
  const Cia402Drive& d = drives_[i];
  r.node = config_.drives[static_cast<std::size_t>(i)].node_id;
  r.nmt_known = hb.seen();
  r.nmt_state = hb.state();
  r.heartbeat_timed_out = hb.timed_out();
  r.cia402_known = d.known();
  r.cia402_state = d.state();
  r.state = (operational(i) && !bus_off_) ? d.drive_state() : DriveState::kOffline;
  r.emcy_active = emcys_[i].active();
  r.last_emcy_code = emcys_[i].last().error_code;
  r.last_emcy_text = emcys_[i].last_text();
  r.own_stop = d.own_stop();
  r.transition_timed_out = d.transition_timed_out();
  r.cycles_since_fresh = cycles_since_fresh_[i];
  r.digital_inputs = digital_inputs_[i];
  r.stop_input = (digital_inputs_[i] & fw::od::kDigitalInputEstopMask) != 0;

  const bool warning_bit = (statusword_[i] & fw::sw::kWarning) != 0;
  if (bus_off_) {
    r.health = DriveHealth::kError, r.reason = "CAN bus-off (latched)";
  } else if (hb.timed_out()) {
    r.health = DriveHealth::kStale, r.reason = "heartbeat timed out";
  } else if (hb.seen() && hb.state() != fw::NmtState::kOperational) {
    r.health = DriveHealth::kError, r.reason = "NMT state not Operational";
  } else if (d.known() && (d.state() == fw::Cia402State::kFault ||
                           d.state() == fw::Cia402State::kFaultReactionActive)) {
    r.health = DriveHealth::kError, r.reason = "CiA 402 fault";
  } else if (emcys_[i].active()) {
    r.health = DriveHealth::kError, r.reason = "EMCY active";
  } else if (d.transition_timed_out()) {
    r.health = DriveHealth::kError, r.reason = "CiA 402 transition timed out";
  } else if (!statusword_current(i)) {
    r.health = DriveHealth::kStale,
    r.reason = "no statusword (TPDO3) within can.statusword_refresh";
  } else if (!ever_fresh_[i] || cycles_since_fresh_[i] >= config_.stale_cycles) {
    r.health = DriveHealth::kStale, r.reason = "no TPDO (position) recently";
  } else if (r.stop_input) {
    r.health = DriveHealth::kWarn, r.reason = "e-stop circuit open (60FDh)";
  } else if (d.own_stop() != StopCause::kNone) {
    r.health = DriveHealth::kWarn, r.reason = "stopped on its own";
  } else if (warning_bit) {
    r.health = DriveHealth::kWarn, r.reason = "statusword warning bit";
  } else if (cycles_since_fresh_[i] > 0) {
    r.health = DriveHealth::kWarn, r.reason = "TPDO missed";
  } else {
    r.health = DriveHealth::kOk, r.reason = "ok";
  }
  return r;
}

}  // namespace dualv::drivers
