#pragma once
// A small scripted CANopen CiA 402 slave for the master's unit tests (not the emulator):
// answers NMT, SDO (expedited and segmented), SYNC (its TPDOs) and takes RPDOs. Where it models
// a conforming slave it is made of the emulator's slave parts (sim/canopen/, library
// dualv_canopen_slave):
// - NMT states, boot-up message, heartbeat producer (1017h): sim::canopen::NmtSlave;
// - the object dictionary (the emulator's objects incl. the PDO records of
//   PdoEngine::add_objects): sim::canopen::ObjectDictionary, served by sim::canopen::SdoServer;
// - PDOs: sim::canopen::PdoEngine, mapped from that dictionary (1400h..1403h, 1600h..1603h,
//   1800h..1803h, 1A00h..1A03h as the master writes them at boot, downloads checked by
//   PdoEngine::check_write; tests that skip the boot write the same records with
//   configure_pdos). At a SYNC the TPDOs are sampled first, then the synchronous RPDOs
//   received since the previous SYNC act (CiA 301 7.3.2): a controlword of RPDO1 (type 1) shows
//   in the statusword of the TPDO after the next SYNC. An RPDO shorter than its mapping is not
//   processed: EMCY 8210h until a correct one;
// - CiA 402 state machine and statusword: sim::canopen::Cia402Slave;
// - a fault's EMCY and the error register 1001h: sim::canopen::EmcyProducer.
// A thin scripted layer on top serves the master's negative tests (the knobs below: aborts on
// request, silence at SYNC, lost NMT starts, ...; send_tpdo repeats the last SYNC's TPDOs,
// send_digital_inputs sends TPDO2 at once) and objects outside the dictionary (strings and
// domains longer than 4 bytes such as 1008h, made-up ones: `od`). Values survive NMT resets (the
// test's set-up stands for the drive's stored parameters). Everything it sends is encoded with
// firmware_if or the slave parts, so no index or COB-ID is written twice. Deterministic: it acts
// only in step(), called by the test (or by StepWaiter), never on a thread; time is the test's
// ManualClock (the PDO engine's: the received frames' timestamps).
#include <cstdint>
#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "drivers/can/in_process_bus.hpp"
#include "drivers/canopen/boot.hpp"
#include "drivers/canopen/clock.hpp"
#include "drivers/canopen/waiter.hpp"
#include "firmware_if/firmware_if.hpp"
#include "sim/canopen/cia402_slave.hpp"
#include "sim/canopen/emcy_producer.hpp"
#include "sim/canopen/nmt_slave.hpp"
#include "sim/canopen/object_dictionary.hpp"
#include "sim/canopen/pdo_engine.hpp"
#include "sim/canopen/sdo_server.hpp"

namespace dualv::drivers::test {

using Key = std::pair<std::uint16_t, std::uint8_t>;

inline std::vector<std::uint8_t> le_bytes(std::uint32_t v, std::size_t n) {
  std::vector<std::uint8_t> b(n);
  for (std::size_t i = 0; i < n; ++i) b[i] = static_cast<std::uint8_t>(v >> (8 * i));
  return b;
}

class FakeSlave {
 public:
  FakeSlave(CanBus& bus, std::uint8_t node)
      : bus_(bus), node_(node), sink_(*this), hooks_(*this), pdo_hooks_(*this) {
    add_objects();
    pdos_.rebuild(dict_);
    emcy_.attach(node, dict_.find(fw::od::kErrorRegister));
    nmt.attach(node, dict_.find(fw::od::kProducerHeartbeat));
    server_.configure(node, {});
    // Booted before the test starts: Pre-operational, its boot-up message not on the bus.
    Discard discard;
    nmt.boot_up(dict_, 0, discard);
    cia402_.power_on();
  }

  // ---- knobs ----
  bool boots = true;  // after an NMT reset: boot-up message, else stays in Initialisation
  bool answers_sdo = true;
  bool answers_sync = true;     // false: the TPDOs due at a SYNC are dropped
  bool ignores_writes = false;  // SDO write confirmed but value not stored (read-back test)
  bool cia402_stuck = false;    // ignores controlwords (transition timeout tests)
  bool fault_reset_works = true;
  // Expedited upload responses without size indication (42h, 4 data bytes, CiA 301
  // 7.2.4.3.6), as some vendors' stacks answer.
  bool upload_without_size = false;
  int ignore_nmt_starts = 0;  // the next n NMT start commands are lost
  std::map<Key, std::uint32_t> abort_on_write;
  std::map<Key, std::uint32_t> abort_on_read;
  std::int32_t position = 0;

  // ---- state ----
  sim::canopen::NmtSlave nmt;  // CiA 301 NMT slave: state(), and what each state allows
  fw::Cia402State cia = fw::Cia402State::kSwitchOnDisabled;
  std::uint16_t controlword = 0;
  std::int16_t target_torque = 0;  // 6071h as the last RPDO wrote it (type 1: at a SYNC)
  // The target torque in effect from each SYNC on (after its RPDOs acted), when Operation
  // enabled.
  std::vector<std::int16_t> applied_torques;
  std::vector<std::uint16_t> controlwords;      // every controlword acted on
  std::map<Key, std::vector<std::uint8_t>> od;  // objects outside the dictionary
  int syncs = 0;

  // An object of the dictionary (else of `od`), as the drive has it.
  void set(const fw::OdEntry& e, std::uint32_t v) {
    if (const int s = dict_.find(e); s >= 0)
      dict_.set(s, v);
    else
      od[{e.index, e.subindex}] = le_bytes(v, e.size());
  }
  std::uint32_t get(const fw::OdEntry& e) const {
    if (const int s = dict_.find(e); s >= 0) return dict_.u(s);
    auto it = od.find({e.index, e.subindex});
    if (it == od.end()) return 0;
    return fw::get_uint_le(it->second.data(), std::min<std::size_t>(4, it->second.size()));
  }
  std::uint8_t node() const { return node_; }
  CanBus& bus() { return bus_; }

  void send(const fw::Result<fw::CanFrame>& f) {
    if (f) (void)bus_.send(*f);
  }
  // A heartbeat with the current NMT state now (outside the producer's period), as
  // CANopenNode sends one on each state change; none in Initialisation.
  void send_heartbeat() {
    fw::NmtState s = fw::NmtState::kPreOperational;
    switch (nmt.state()) {
      case sim::canopen::NmtSlaveState::kInitialisation:
        return;
      case sim::canopen::NmtSlaveState::kPreOperational:
        break;
      case sim::canopen::NmtSlaveState::kOperational:
        s = fw::NmtState::kOperational;
        break;
      case sim::canopen::NmtSlaveState::kStopped:
        s = fw::NmtState::kStopped;
        break;
    }
    send(fw::encode_heartbeat(node_, s));
  }
  void send_emcy(std::uint16_t code, std::uint8_t reg = 0) {
    fw::Emcy e;
    e.node = node_;
    e.error_code = code;
    e.error_register = reg;
    send(fw::encode_emcy(e));
  }
  std::uint16_t statusword() const { return cia402_.statusword(); }
  std::uint8_t error_register() const { return emcy_.error_register(); }
  // The digital inputs 60FDh change to `di`, and the event-driven TPDO2 (as the master maps
  // it: 60FDh, 4 bytes on 280h + id) goes out at once, as a drive sends one on the event
  // (scripted: the PdoEngine sends event-driven TPDOs at a SYNC or on their timers only; at
  // the next SYNC it sends the changed 60FDh again).
  void send_digital_inputs(std::uint32_t di) {
    dict_.set(dict_.find(fw::od::kDigitalInputs), di);
    fw::CanFrame f;
    f.id = fw::cob_id(fw::Function::kTpdo2, node_);
    f.dlc = 4;
    fw::put_u32_le(f.data.data(), di);
    (void)bus_.send(f);
  }
  // Scripted: the TPDOs the engine sent at the last SYNC, once more (a duplicate).
  void send_tpdo() {
    for (const fw::CanFrame& f : last_tpdos_) (void)bus_.send(f);
  }
  // The PDO configuration the master writes at boot for drive `drive` of `config`
  // (drivers/canopen/boot.hpp boot_writes: the 1400h../1600h../1800h../1A00h.. writes, in
  // order), through the same checks as an SDO download (PdoEngine::check_write), for tests
  // that skip the boot. Throws std::runtime_error naming the entry when one is refused.
  void configure_pdos(const CanConfig& config, int drive) {
    for (const canopen::ConfigWrite& w : canopen::boot_writes(config, drive)) {
      if (!sim::canopen::PdoEngine::is_parameter(w.entry.index)) continue;
      const int s = dict_.find(w.entry);
      const std::uint32_t abort = s < 0 ? 0x06020000u : hooks_.download(s, w.value);
      if (abort != 0) {
        char what[160];
        std::snprintf(what, sizeof what,
                      "FakeSlave::configure_pdos: node %u refused %04Xh sub%u = %08Xh (%s): %08Xh",
                      node_, w.entry.index, w.entry.subindex, w.value, w.why, abort);
        throw std::runtime_error(what);
      }
    }
  }
  // The drive faults on its own (e.g. over-temperature): EMCY + Fault.
  // The EMCY carries the error register of the code's class (4210h: generic + temperature);
  // a fault reset sends EMCY 0000h (sim::canopen::EmcyProducer).
  void fault(std::uint16_t code = fw::emcy::kDeviceOverTemperature) {
    cia402_.fault();
    cia = cia402_.state();
    emcy_.raise(dict_, kFaultCondition, code, true, sink_);
  }

  // The drive's heartbeat producer (NmtSlave, 1017h as configured by the master): call with
  // the current time; sends when due (Pre-operational, Operational, Stopped), the period
  // counted from the boot-up or the last write of 1017h.
  void tick(std::uint64_t now_ns) {
    now_ns_ = now_ns;
    (void)nmt.on_time(dict_, now_ns, sink_);
  }

  // Processes every frame received, answering as a drive would.
  void step() {
    fw::CanFrame f;
    while (bus_.receive(f) == BusStatus::kOk) handle(f);
  }

 private:
  void handle(const fw::CanFrame& f) {
    const fw::Result<fw::CobIdInfo> info = fw::classify(f);
    if (!info) return;
    switch (info->function) {
      case fw::Function::kNmt: {
        const auto m = fw::decode_nmt(f);
        if (!m || !fw::addressed_to(*m, node_)) return;
        if (m->command == fw::NmtCommand::kStart && ignore_nmt_starts > 0) {
          --ignore_nmt_starts;  // lost on the way
          return;
        }
        const sim::canopen::NmtChange change = nmt.on_command(m->command);
        if (!nmt.pdo_allowed()) pdos_.stop();  // PDOs exist in Operational only
        if (change.reset_application || change.reset_communication) {
          cia402_.power_on();
          cia = cia402_.state();
          emcy_.reset();
          if (boots) {
            server_.reset();
            nmt.boot_up(dict_, now_ns_, sink_);
          } else
            nmt.hold_in_initialisation();
        } else if (change.from != sim::canopen::NmtSlaveState::kInitialisation) {
          send_heartbeat();
        }
        return;
      }
      case fw::Function::kSync:
        if (!nmt.pdo_allowed()) return;
        ++syncs;
        // The synchronous TPDOs sampled from the dictionary (CiA 301 7.3.2); answers_sync
        // = false drops them (the scripted layer).
        last_tpdos_.clear();
        refresh();
        pdos_.transmit_at_sync(dict_, pdo_hooks_, f.timestamp_ns);
        // Then the synchronous RPDOs received since the previous SYNC take effect (CiA 301
        // 7.3.2), as in the emulator.
        pdos_.latch_at_sync(dict_, pdo_hooks_, f.timestamp_ns);
        if (cia == fw::Cia402State::kOperationEnabled) applied_torques.push_back(target_torque);
        return;
      case fw::Function::kRpdo1:
        on_rpdo(f);
        return;
      case fw::Function::kBroadcastRpdo:  // 200h: RPDO2 of the broadcast and fd layouts
        on_rpdo(f);
        return;
      case fw::Function::kSdoRx:
        if (info->node == node_ && answers_sdo && nmt.sdo_allowed()) sdo(f);
        return;
      default:
        return;
    }
  }

 private:
  // An RPDO through the engine: written into the dictionary (at once, or at the next SYNC
  // for the synchronous types), acted on in PdoAdapter::written. One shorter than its
  // mapping is not processed: EMCY 8210h until a correct one (CiA 301 7.2.2.2).
  void on_rpdo(const fw::CanFrame& f) {
    const sim::canopen::RpdoReceipt r =
        pdos_.on_rpdo(f, nmt.pdo_allowed(), dict_, pdo_hooks_, f.timestamp_ns);
    if (r.too_short && !emcy_.active(kPdoLengthCondition))
      emcy_.raise(dict_, kPdoLengthCondition, fw::emcy::kPdoLengthError, true, sink_);
    if (r.accepted) emcy_.clear(dict_, kPdoLengthCondition, true, sink_);
  }
  void on_controlword(std::uint16_t cw) {
    controlword = cw;
    controlwords.push_back(cw);
    if (cia402_stuck) return;
    // The emulator's CiA 402 slave (firmware_if's transition table). Its quick stop never
    // "stops" here (no on_sync): Quick stop active until disable voltage, as a drive still
    // decelerating; no 16 (605Ah 2).
    const sim::canopen::ControlwordEffect e =
        cia402_.on_controlword(cw, static_cast<std::int16_t>(fw::QuickStopOption::kQuickStopRamp),
                               false, !fault_reset_works);
    cia = cia402_.state();
    if (e == sim::canopen::ControlwordEffect::kFaultReset)
      emcy_.clear(dict_, kFaultCondition, true, sink_);
  }

  // The scripted layer first (aborts on request, objects outside the dictionary), then the
  // SdoServer; a segment goes to whichever started the transfer.
  void sdo(const fw::CanFrame& f) {
    const auto r = fw::decode_sdo_request(f);
    if (r && r->type == fw::SdoType::kAbort) {
      aborts_received.push_back(r->abort_code);
      server_.reset();
      return;
    }
    if (r) {
      const fw::SdoMessage& m = *r;
      const Key k{m.index, m.subindex};
      const bool initiate =
          m.type == fw::SdoType::kDownloadInitiate || m.type == fw::SdoType::kUploadInitiate;
      if (initiate) {
        const auto& aborts =
            m.type == fw::SdoType::kDownloadInitiate ? abort_on_write : abort_on_read;
        if (auto it = aborts.find(k); it != aborts.end()) {
          server_.reset();
          send(fw::sdo_abort(node_, fw::SdoRole::kServer, m.index, m.subindex, it->second));
          return;
        }
        scripted_transfer_ = dict_.find(m.index, m.subindex) < 0;
      }
      if (scripted_transfer_) {
        if (initiate) server_.reset();
        scripted_sdo(m);
        return;
      }
    }
    server_.configure(node_, {false, upload_without_size});
    fw::CanFrame response;
    if (server_.on_request(f, dict_, hooks_, response)) (void)bus_.send(response);
  }

  // An object outside the dictionary: stored as the bytes written, read back as stored.
  void scripted_sdo(const fw::SdoMessage& m) {
    const Key k{m.index, m.subindex};
    switch (m.type) {
      case fw::SdoType::kDownloadInitiate:
        if (m.expedited) {
          if (!ignores_writes)
            store(k, std::vector<std::uint8_t>(m.data.begin(), m.data.begin() + m.data_len));
        } else {
          seg_key_ = k;
          seg_buf_.assign(m.size, 0);
          rx_ = fw::SdoSegmentReceiver(seg_buf_);
          rx_.begin(m.size);
        }
        send(fw::sdo_download_initiate_response(node_, m.index, m.subindex));
        return;
      case fw::SdoType::kDownloadSegment: {
        if (rx_.accept(m) != fw::Error::kNone) {
          send(fw::sdo_abort(node_, fw::SdoRole::kServer, seg_key_.first, seg_key_.second,
                             fw::SdoAbortCode::kToggleNotAlternated));
          return;
        }
        send(fw::sdo_download_segment_response(node_, m.toggle));
        if (rx_.done())
          store(seg_key_, std::vector<std::uint8_t>(rx_.bytes().begin(), rx_.bytes().end()));
        return;
      }
      case fw::SdoType::kUploadInitiate: {
        auto it = od.find(k);
        if (it == od.end()) {
          send(fw::sdo_abort(node_, fw::SdoRole::kServer, m.index, m.subindex,
                             fw::SdoAbortCode::kObjectDoesNotExist));
          return;
        }
        if (it->second.size() <= 4 && upload_without_size) {
          fw::CanFrame response;
          response.id = fw::cob_id(fw::Function::kSdoTx, node_);
          response.dlc = 8;
          response.data = {0x42, static_cast<std::uint8_t>(m.index),
                           static_cast<std::uint8_t>(m.index >> 8), m.subindex};
          std::copy(it->second.begin(), it->second.end(), response.data.begin() + 4);
          (void)bus_.send(response);
        } else if (it->second.size() <= 4) {
          send(fw::sdo_upload_expedited_response(node_, m.index, m.subindex, it->second));
        } else {
          up_buf_ = it->second;
          tx_.begin(up_buf_);
          send(fw::sdo_upload_initiate_response(node_, m.index, m.subindex,
                                                static_cast<std::uint32_t>(up_buf_.size())));
        }
        return;
      }
      case fw::SdoType::kUploadSegment: {
        const auto s = tx_.next();
        send(fw::sdo_upload_segment_response(node_, s.toggle, s.bytes, s.last));
        return;
      }
      case fw::SdoType::kAbort:
        return;  // handled in sdo()
    }
  }

 public:
  std::vector<std::uint32_t> aborts_received;

 private:
  void store(const Key& k, std::vector<std::uint8_t> bytes) { od[k] = std::move(bytes); }

  // The emulator's objects (sim/drive_emulator.cpp build()) with this drive's values.
  void add_objects() {
    namespace o = fw::od;
    dict_.add(o::kDeviceType, 0x00020000u | o::kDeviceProfileCia402);  // servo drive
    dict_.add(o::kErrorRegister, 0);
    dict_.add(o::kCobIdSync, fw::kSyncCobId);
    dict_.add(o::kCommunicationCyclePeriod, 0);
    dict_.add(o::kCobIdEmcy, fw::cob_id(fw::Function::kEmcy, node_));
    dict_.add(o::kConsumerHeartbeatCount, 1);
    dict_.add(o::consumer_heartbeat(1), 0);
    dict_.add(o::kProducerHeartbeat, 0);
    dict_.add(o::kSyncCounterOverflow, 0);
    dict_.add(o::kAbortConnectionOption, 0);
    dict_.add(o::kErrorCode, 0);
    dict_.add(o::kControlword, 0);
    dict_.add(o::kStatusword, 0);
    dict_.add(o::kQuickStopOption, 0);
    dict_.add(o::kShutdownOption, 0);
    dict_.add(o::kDisableOperationOption, 0);
    dict_.add(o::kHaltOption, 0);
    dict_.add(o::kFaultReactionOption, 0);
    dict_.add(o::kModesOfOperation, 0);
    dict_.add(o::kModesOfOperationDisplay, 0);
    dict_.add(o::kPositionActual, 0);
    dict_.add(o::kVelocityActual, 0);
    dict_.add(o::kTargetTorque, 0);
    dict_.add(o::kMaxTorque, 0);
    dict_.add(o::kRatedTorque, 50000);
    dict_.add(o::kTorqueActual, 0);
    dict_.add(o::kEncoderResolutionCount, o::kEncoderMotorRevolutions.subindex);
    dict_.add(o::kEncoderIncrements, 1u << 20);
    dict_.add(o::kEncoderMotorRevolutions, 1);
    dict_.add(o::kInterpolationPeriodCount, o::kInterpolationPeriodIndex.subindex);
    dict_.add(o::kInterpolationPeriodValue, 1);
    dict_.add(o::kInterpolationPeriodIndex, static_cast<std::uint8_t>(-3));
    dict_.add(o::kDigitalInputs, 0);
    dict_.add(o::kSupportedDriveModes,
              fw::supported_mode_bit(fw::ModeOfOperation::kCyclicSyncTorque));
    sim::canopen::PdoEngine::add_objects(dict_, node_);
  }

  // Behind the SdoServer: a download is stored (unless ignores_writes); 1017h restarts the
  // heartbeat producer.
  struct Hooks final : sim::canopen::SdoServerHooks {
    explicit Hooks(FakeSlave& s) : slave(s) {}
    std::uint32_t download(int slot, std::uint32_t value) noexcept override {
      const fw::OdEntry& e = slave.dict_.entry(slot);
      // PDO records: CiA 301 7.5.2.35..38 (valid COB-ID, mapping only while invalid, ...).
      if (const std::uint32_t abort = slave.pdos_.check_write(slave.dict_, e, value); abort != 0)
        return abort;
      if (slave.ignores_writes) return 0;
      slave.dict_.set(slot, value);
      if (sim::canopen::PdoEngine::is_parameter(e.index)) slave.pdos_.rebuild(slave.dict_);
      if (slot == slave.dict_.find(fw::od::kProducerHeartbeat))
        slave.nmt.producer_time_written(slave.dict_, slave.now_ns_);
      return 0;
    }
    void before_upload(int) noexcept override {}
    FakeSlave& slave;
  };
  // Behind the PdoEngine: TPDOs out (unless answers_sync is false), values to sample.
  struct PdoAdapter final : sim::canopen::PdoHooks {
    explicit PdoAdapter(FakeSlave& s) : slave(s) {}
    void transmit(const fw::CanFrame& f) noexcept override {
      if (!slave.answers_sync) return;
      (void)slave.bus_.send(f);
      slave.last_tpdos_.push_back(f);
    }
    // A mapped object written by an RPDO: the controlword acts, the target torque is taken.
    void written(int slot, std::uint64_t) noexcept override {
      if (slot == slave.dict_.find(fw::od::kControlword))
        slave.on_controlword(static_cast<std::uint16_t>(slave.dict_.u(slot)));
      else if (slot == slave.dict_.find(fw::od::kTargetTorque))
        slave.target_torque = static_cast<std::int16_t>(slave.dict_.u(slot));
    }
    void before_sample() noexcept override { slave.refresh(); }
    FakeSlave& slave;
  };
  // The application's values into the dictionary before the engine samples them.
  void refresh() {
    dict_.set(dict_.find(fw::od::kStatusword), statusword());
    dict_.set(dict_.find(fw::od::kPositionActual), static_cast<std::uint32_t>(position));
  }
  struct Discard final : sim::canopen::FrameSink {
    void send(const fw::CanFrame&) noexcept override {}
  };
  struct Sink final : sim::canopen::FrameSink {
    explicit Sink(FakeSlave& s) : slave(s) {}
    void send(const fw::CanFrame& f) noexcept override { (void)slave.bus_.send(f); }
    FakeSlave& slave;
  };
  static constexpr int kFaultCondition = 0;
  static constexpr int kPdoLengthCondition = 1;  // 8210h: an RPDO shorter than its mapping

  CanBus& bus_;
  std::uint8_t node_;
  Sink sink_;
  sim::canopen::Cia402Slave cia402_;
  Hooks hooks_;
  sim::canopen::ObjectDictionary dict_;  // 1001h owned by emcy_, 1017h read by nmt
  sim::canopen::SdoServer server_;
  sim::canopen::PdoEngine pdos_;  // mapped from dict_ (1400h..1A03h as the master writes them)
  PdoAdapter pdo_hooks_;
  std::vector<fw::CanFrame> last_tpdos_;  // sent at the last SYNC (send_tpdo)
  bool scripted_transfer_ = false;        // the SDO transfer under way is the scripted layer's
  sim::canopen::EmcyProducer emcy_;
  std::uint64_t now_ns_ = 0;  // the last tick()
  Key seg_key_{};
  std::vector<std::uint8_t> seg_buf_;
  fw::SdoSegmentReceiver rx_{std::span<std::uint8_t>{}};
  std::vector<std::uint8_t> up_buf_;
  fw::SdoSegmentSender tx_{};
};

// The deterministic waiter: each wait runs the fake slaves once and advances the clock by
// one step (never past the deadline), stamping the hub with the new time.
class StepWaiter final : public canopen::Waiter {
 public:
  StepWaiter(canopen::ManualClock& clock, InProcessHub& hub, std::vector<FakeSlave*> slaves,
             std::uint64_t step_ns = 1'000'000)
      : clock_(clock), hub_(hub), slaves_(std::move(slaves)), step_ns_(step_ns) {}
  void wait_until(std::uint64_t deadline_ns) override {
    for (FakeSlave* s : slaves_) s->step();
    const std::uint64_t now = clock_.now_ns();
    if (deadline_ns > now) clock_.advance_ns(std::min(step_ns_, deadline_ns - now));
    hub_.set_time_ns(clock_.now_ns());
    ++waits;
  }
  int waits = 0;

 private:
  canopen::ManualClock& clock_;
  InProcessHub& hub_;
  std::vector<FakeSlave*> slaves_;
  std::uint64_t step_ns_;
};

// Every frame seen by a passive endpoint, as "ID#DATA" (candump's compact form).
inline std::string to_text(const fw::CanFrame& f) {
  static const char* hex = "0123456789ABCDEF";
  std::string s;
  for (int shift = 8; shift >= 0; shift -= 4) s += hex[(f.id >> shift) & 0xF];
  s += '#';
  for (std::size_t i = 0; i < f.dlc; ++i) {
    s += hex[f.data[i] >> 4];
    s += hex[f.data[i] & 0xF];
  }
  return s;
}

// The inverse of to_text: "581#4217100032000000" (hex id, '#', 0..8 hex bytes).
inline fw::CanFrame from_text(const std::string& text) {
  fw::CanFrame f;
  const std::size_t hash = text.find('#');
  f.id = static_cast<std::uint32_t>(std::stoul(text.substr(0, hash), nullptr, 16));
  const std::string data = text.substr(hash + 1);
  f.dlc = static_cast<std::uint8_t>(data.size() / 2);
  for (std::size_t i = 0; i < f.dlc; ++i)
    f.data[i] = static_cast<std::uint8_t>(std::stoul(data.substr(2 * i, 2), nullptr, 16));
  return f;
}

inline std::vector<fw::CanFrame> drain(InProcessBus& bus) {
  std::vector<fw::CanFrame> out;
  fw::CanFrame f;
  while (bus.receive(f) == BusStatus::kOk) out.push_back(f);
  return out;
}

}  // namespace dualv::drivers::test
