#include "drivers/canopen/boot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iterator>

#include "common/config_error.hpp"
#include "firmware_if/heartbeat.hpp"
#include "firmware_if/pdo.hpp"
#include "firmware_if/units.hpp"

namespace dualv::drivers::canopen {

namespace {

using fw::od::PdoDirection;

std::uint16_t ms(std::uint64_t ns) { return static_cast<std::uint16_t>(ns / 1'000'000); }

void add_pdo(std::vector<ConfigWrite>& w, PdoDirection dir, std::uint8_t number,
             std::uint16_t cob_id, const fw::PdoLayout& layout, std::uint8_t transmission,
             std::uint16_t event_timer_ms, bool write_event_timer,
             std::uint16_t inhibit_100us = 0) {
  const bool rpdo = dir == PdoDirection::kRpdo;
  // RPDO: bit 30 is reserved (written 0); TPDO: no RTR (bit 30 set).
  const bool rtr_allowed = rpdo;
  w.push_back({fw::od::pdo_cob_id(dir, number), fw::pdo_cob_id_value(cob_id, false, rtr_allowed),
               "PDO invalid while its mapping changes"});
  w.push_back({fw::od::pdo_mapping_count(dir, number), 0, "clear mapping"});
  for (std::uint8_t i = 0; i < layout.count; ++i)
    w.push_back({fw::od::pdo_mapping_entry(dir, number, static_cast<std::uint8_t>(i + 1)),
                 fw::encode_mapping(layout.entries[i]), "mapping entry"});
  w.push_back({fw::od::pdo_mapping_count(dir, number), layout.count, "mapping count"});
  w.push_back({fw::od::pdo_transmission_type(dir, number), transmission, "transmission type"});
  if (inhibit_100us != 0)
    w.push_back({fw::od::pdo_inhibit_time(dir, number), inhibit_100us, "inhibit time (100 us)"});
  if (write_event_timer)
    w.push_back({fw::od::pdo_event_timer(dir, number), event_timer_ms,
                 rpdo ? "RPDO deadline (event timer)" : "event timer"});
  w.push_back({fw::od::pdo_cob_id(dir, number), fw::pdo_cob_id_value(cob_id, true, rtr_allowed),
               "PDO valid"});
}

// Marks the writes from `first` on as belonging to the non-mandatory object `key`.
void tag(std::vector<ConfigWrite>& w, std::size_t first, const char* key, ObjectPolicy p) {
  for (std::size_t i = first; i < w.size(); ++i) {
    w[i].object = key;
    w[i].policy = p;
  }
}

// The drive has no such object / sub-index (or cannot map it): what an optional object
// may be skipped for.
bool means_absent(std::uint32_t code, const fw::OdEntry& e) {
  using C = fw::SdoAbortCode;
  if (code == static_cast<std::uint32_t>(C::kObjectDoesNotExist) ||
      code == static_cast<std::uint32_t>(C::kSubindexDoesNotExist))
    return true;
  const bool mapping = (e.index >= fw::od::kRpdoMappingBase && e.index < 0x1800) ||
                       (e.index >= fw::od::kTpdoMappingBase && e.index < 0x1C00);
  return mapping && code == static_cast<std::uint32_t>(C::kCannotBeMapped);
}

// A write of an RPDO mapping entry (1600h..17FFh sub1..) that maps a dummy (0002h..0007h).
bool is_dummy_mapping(const ConfigWrite& w) {
  return w.entry.index >= fw::od::kRpdoMappingBase && w.entry.index < 0x1800 &&
         w.entry.subindex >= 1 && fw::is_dummy(fw::decode_mapping(w.value));
}

// The write of the FD RPDO's mapping count (CAN FD layout): more than 64 bits, which a
// classic CANopen drive aborts (06040042h, CiA 301 7.5.2.36).
bool is_fd_mapping_count(const ConfigWrite& w, const CanConfig& c) {
  return c.bus_layout == fw::BusLayout::kFd &&
         w.entry.index == fw::od::kRpdoMappingBase + fw::kFdRpdoNumber - 1 &&
         w.entry.subindex == 0 && w.value != 0;
}

std::uint32_t raw16(std::int16_t v) { return static_cast<std::uint16_t>(v); }

std::uint32_t mask(const fw::OdEntry& e) {
  return e.size() >= 4 ? 0xFFFFFFFFu : ((1u << (8 * e.size())) - 1u);
}

}  // namespace

bool interpolation_period(std::uint64_t period_ns, std::uint8_t& value,
                          std::int8_t& index) noexcept {
  // Largest exponent that writes the period exactly: 1 ms -> 1 x 10^-3, 2.5 ms -> 25 x 10^-4.
  for (int exp = 0; exp >= -9; --exp) {
    const double unit_ns = std::pow(10.0, 9 + exp);
    const double v = static_cast<double>(period_ns) / unit_ns;
    if (v <= 255.0 && v >= 1.0 && std::fabs(v - std::round(v)) < 1e-9) {
      value = static_cast<std::uint8_t>(std::lround(v));
      index = static_cast<std::int8_t>(exp);
      return true;
    }
  }
  return false;
}

std::vector<ConfigWrite> boot_writes(const CanConfig& c, int drive) {
  const CanDriveConfig& d = c.drives.at(static_cast<std::size_t>(drive));
  const BootObjects& o = d.objects;
  const std::uint8_t id = d.node_id;
  std::vector<ConfigWrite> w;
  // Adds the writes `add` makes as the object `key` with policy `p` (none when off).
  auto object = [&w](const char* key, ObjectPolicy p, auto add) {
    if (p == ObjectPolicy::kOff) return;
    const std::size_t first = w.size();
    add();
    tag(w, first, key, p);
  };
  w.push_back(
      {fw::od::kProducerHeartbeat, ms(c.drive_heartbeat_period_ns), "drive heartbeat (1017h)"});

  const std::uint16_t deadline = ms(c.rpdo_deadline_ns);
  const auto drives = static_cast<std::uint8_t>(c.drives.size());
  if (c.bus_layout == fw::BusLayout::kPerDrive) {
    add_pdo(w, PdoDirection::kRpdo, 1, fw::cob_id(fw::Function::kRpdo1, id), fw::kRpdo1Layout,
            fw::kTransmissionSyncEvery, deadline, true);
  } else if (c.bus_layout == fw::BusLayout::kFd) {
    // RPDO1 off (its COB-ID 200h+id stays unused); the FD RPDO2 on 200h carries the
    // controlword + torque of every drive, applied at SYNC, with the deadline.
    w.push_back({fw::od::pdo_cob_id(PdoDirection::kRpdo, 1),
                 fw::pdo_cob_id_value(fw::cob_id(fw::Function::kRpdo1, id), false, true),
                 "RPDO1 not valid (fd: the FD RPDO carries the controlword)"});
    add_pdo(w, PdoDirection::kRpdo, fw::kFdRpdoNumber, fw::kBroadcastRpdoCobId,
            fw::fd_rpdo_layout(static_cast<std::uint8_t>(drive), drives),
            fw::kTransmissionSyncEvery, deadline, true);
  } else {
    // Controlword alone in RPDO1, applied on receipt (event driven); the torques in the
    // broadcast RPDO2, applied at SYNC, with the deadline.
    add_pdo(w, PdoDirection::kRpdo, 1, fw::cob_id(fw::Function::kRpdo1, id),
            fw::kControlwordRpdoLayout, fw::kTransmissionEventProfile, 0, true);
    add_pdo(w, PdoDirection::kRpdo, fw::kBroadcastRpdoNumber, fw::kBroadcastRpdoCobId,
            fw::broadcast_rpdo_layout(static_cast<std::uint8_t>(drive),
                                      static_cast<std::uint8_t>(c.drives.size())),
            fw::kTransmissionSyncEvery, deadline, true);
  }
  if (c.bus_layout != fw::BusLayout::kBroadcast) {  // per_drive and fd: the same TPDO1
    add_pdo(w, PdoDirection::kTpdo, 1, fw::cob_id(fw::Function::kTpdo1, id), fw::kTpdo1Layout,
            fw::kTransmissionSyncEvery, 0, false);
  } else {
    // Position alone every SYNC; the statusword on change, at most once per inhibit time
    // and at least once per event timer (CiA 301 7.5.2.37 sub3 / sub5).
    add_pdo(w, PdoDirection::kTpdo, 1, fw::cob_id(fw::Function::kTpdo1, id),
            fw::kPositionTpdoLayout, fw::kTransmissionSyncEvery, 0, false);
    add_pdo(w, PdoDirection::kTpdo, fw::kStatuswordTpdoNumber,
            fw::cob_id(fw::tpdo_function(fw::kStatuswordTpdoNumber), id), fw::kStatuswordTpdoLayout,
            fw::kTransmissionEventProfile, ms(c.statusword_refresh_ns), true,
            static_cast<std::uint16_t>(c.statusword_inhibit_ns / 100'000u));
  }
  if (c.digital_inputs_refresh_ns != 0)
    object("digital_inputs", o.digital_inputs, [&] {
      add_pdo(w, PdoDirection::kTpdo, kDigitalInputsTpdo,
              fw::cob_id(fw::tpdo_function(kDigitalInputsTpdo), id), kDigitalInputsTpdoLayout,
              fw::kTransmissionEventProfile, ms(c.digital_inputs_refresh_ns), true, 10);
    });

  w.push_back({fw::od::kModesOfOperation,
               static_cast<std::uint8_t>(fw::ModeOfOperation::kCyclicSyncTorque),
               "cyclic synchronous torque (6060h = 10)"});
  w.push_back({fw::od::kMaxTorque, fw::max_torque_per_mille(d.max_torque, d.rated_torque),
               "max torque (6072h, per mille of rated)"});
  object("quick_stop", o.quick_stop, [&] {
    w.push_back({fw::od::kQuickStopOption, raw16(static_cast<std::int16_t>(c.quick_stop)),
                 "quick stop option (605Ah)"});
  });
  object("fault_reaction", o.fault_reaction, [&] {
    w.push_back({fw::od::kFaultReactionOption, raw16(static_cast<std::int16_t>(c.fault_reaction)),
                 "fault reaction option (605Eh)"});
  });
  object("abort_connection", o.abort_connection, [&] {
    w.push_back({fw::od::kAbortConnectionOption,
                 raw16(static_cast<std::int16_t>(c.abort_connection)),
                 "abort connection option (6007h)"});
  });
  object("cycle_period", o.cycle_period, [&] {
    w.push_back({fw::od::kCommunicationCyclePeriod,
                 static_cast<std::uint32_t>(c.sync_period_ns / 1000u),
                 "communication cycle period (1006h, us)"});
  });
  std::uint8_t value = 0;
  std::int8_t index = 0;
  if (interpolation_period(c.sync_period_ns, value, index)) {
    object("interpolation_period", o.interpolation_period, [&] {
      w.push_back({fw::od::kInterpolationPeriodValue, value, "interpolation period value (60C2h)"});
      w.push_back({fw::od::kInterpolationPeriodIndex, static_cast<std::uint8_t>(index),
                   "interpolation period index (60C2h)"});
    });
  }
  if (c.sync_counter_overflow != 0)
    w.push_back({fw::od::kSyncCounterOverflow, c.sync_counter_overflow, "SYNC counter (1019h)"});
  object("consumer_heartbeat", o.consumer_heartbeat, [&] {
    w.push_back({fw::od::consumer_heartbeat(1),
                 fw::consumer_heartbeat_value(c.master_node_id, ms(c.master_heartbeat_timeout_ns)),
                 "consumer heartbeat of the master (1016h)"});
  });
  return w;
}

namespace {

void check_parameters(CanopenMaster& m, const CanConfig& c, int i) {
  const CanDriveConfig& d = c.drives[static_cast<std::size_t>(i)];
  const std::uint8_t id = d.node_id;
  std::vector<std::string> problems;
  std::uint32_t v[std::size(kParameterReads)] = {};
  for (std::size_t k = 0; k < std::size(kParameterReads); ++k)
    v[k] = m.read(id, kParameterReads[k]);
  const auto [type, modes, rated, inc, revs] = v;
  if ((type & 0xFFFFu) != fw::od::kDeviceProfileCia402)
    problems.push_back(fmt::format(
        "can.drives[{}].node_id: node {} is not a CiA 402 drive (1000h device type {:08X}h)", i, id,
        type));
  if ((modes & fw::supported_mode_bit(fw::ModeOfOperation::kCyclicSyncTorque)) == 0)
    problems.push_back(
        fmt::format("can.drives[{}].node_id: node {} does not support cyclic synchronous torque "
                    "(6502h = {:08X}h)",
                    i, id, modes));
  const auto expected_rated = static_cast<std::uint32_t>(std::llround(d.rated_torque * 1000.0));
  if (rated != expected_rated)
    problems.push_back(fmt::format(
        "can.drives[{}].rated_torque: {} N m but node {} reports 6076h = {} mN m ({} N m)", i,
        d.rated_torque, id, rated, rated / 1000.0));
  const std::uint32_t cpr = fw::counts_per_rev(inc, revs);
  if (cpr != d.counts_per_revolution)
    problems.push_back(fmt::format(
        "can.drives[{}].counts_per_revolution: {} but node {} reports 608Fh = {} / {} = {}", i,
        d.counts_per_revolution, id, inc, revs, cpr));
  if (!problems.empty()) throw ConfigError(problems);
}

void configure(CanopenMaster& m, const CanConfig& c, int i, std::vector<SkippedObject>& skipped,
               const std::function<void(const std::string&)>& log) {
  const std::uint8_t id = c.drives[static_cast<std::size_t>(i)].node_id;
  const char* skipping = nullptr;  // the optional object being skipped
  for (const ConfigWrite& w : boot_writes(c, i)) {
    if (skipping != nullptr && w.object != nullptr && std::string(w.object) == skipping) continue;
    skipping = nullptr;
    std::uint32_t back = 0;
    try {
      m.write(id, w.entry, w.value);
      back = m.read(id, w.entry);
    } catch (const SdoError& e) {
      if (e.status() == SdoStatus::kAborted && is_dummy_mapping(w))
        throw SdoError(
            fmt::format("node {} (can.drives[{}]) refuses the CiA 301 dummy mapping entry {:04X}h "
                        "({} bits) in {}: aborted {:08X}h {}. This drive cannot run "
                        "can.bus_layout: {}; use per_drive",
                        id, i, fw::decode_mapping(w.value).index, fw::decode_mapping(w.value).bits,
                        describe(w.entry), e.code(), fw::sdo_abort_text(e.code()),
                        fw::to_string(c.bus_layout)),
            e.node(), e.index(), e.subindex(), e.status(), e.code());
      if (e.status() == SdoStatus::kAborted && is_fd_mapping_count(w, c))
        throw SdoError(
            fmt::format("node {} (can.drives[{}]) refuses the {}-byte CAN FD RPDO mapping ({} "
                        "entries in {}): aborted {:08X}h {}. This drive is not a CAN FD "
                        "(CiA 1301) device, its PDOs end at 8 bytes: it cannot run "
                        "can.bus_layout: fd; use per_drive or broadcast",
                        id, i, fw::fd_rpdo_bytes(static_cast<std::uint8_t>(c.drives.size())),
                        w.value, describe(w.entry), e.code(), fw::sdo_abort_text(e.code())),
            e.node(), e.index(), e.subindex(), e.status(), e.code());
      if (w.object == nullptr || w.policy != ObjectPolicy::kOptional ||
          e.status() != SdoStatus::kAborted || !means_absent(e.code(), w.entry)) {
        if (w.object != nullptr && w.policy == ObjectPolicy::kRequired &&
            e.status() == SdoStatus::kAborted && means_absent(e.code(), w.entry))
          throw SdoError(fmt::format("{} (can.objects.{} is required; make it optional to boot "
                                     "this drive without it)",
                                     e.what(), w.object),
                         e.node(), e.index(), e.subindex(), e.status(), e.code());
        throw;
      }
      SkippedObject s{id, w.object,
                      fmt::format("{} aborted {:08X}h {}", describe(w.entry), e.code(),
                                  fw::sdo_abort_text(e.code()))};
      if (log) log(describe(s));
      skipped.push_back(std::move(s));
      skipping = w.object;
      continue;
    }
    if ((back & mask(w.entry)) != (w.value & mask(w.entry)))
      throw CanopenError(fmt::format(
          "node {}: {} ({}) read back {:#x} after writing {:#x}: the drive did not take the value",
          id, describe(w.entry), w.why, back, w.value));
  }
}

// NMT start (CiA 301 7.2.8.3.1), then wait for each heartbeat to say Operational. NMT
// commands are unconfirmed: a node that missed one (a lost frame) gets it again every few
// heartbeat periods until can.timeouts.boot.
void start_nodes(CanopenMaster& m, const CanConfig& c, const std::vector<std::uint8_t>& nodes) {
  const std::uint64_t deadline = m.clock().now_ns() + c.boot_timeout_ns;
  const std::uint64_t slice = std::max<std::uint64_t>(3 * c.drive_heartbeat_period_ns, 100'000'000);
  std::vector<std::uint8_t> missing = nodes;
  int sent = 0;
  for (;;) {
    for (std::uint8_t id : missing) m.nmt(fw::NmtCommand::kStart, id);
    ++sent;
    const std::uint64_t now = m.clock().now_ns();
    const std::uint64_t wait = deadline > now ? std::min(slice, deadline - now) : 0;
    try {
      m.wait_state(missing, fw::NmtState::kOperational, wait);
      return;
    } catch (const BootTimeoutError& e) {
      if (m.clock().now_ns() >= deadline)
        throw BootTimeoutError(
            fmt::format("{} (NMT start sent {} times within can.timeouts.boot = {} s)", e.what(),
                        sent, static_cast<double>(c.boot_timeout_ns) / 1e9),
            e.nodes());
      missing = e.nodes();
    }
  }
}

}  // namespace

std::string describe(const SkippedObject& s) {
  return fmt::format("node {}: {} skipped (optional): {}", s.node, s.object, s.detail);
}

std::vector<SkippedObject> boot_drives(CanopenMaster& m, const CanConfig& c,
                                       const std::function<void(const std::string&)>& log) {
  std::vector<SkippedObject> skipped;
  std::vector<std::uint8_t> nodes;
  for (const CanDriveConfig& d : c.drives) nodes.push_back(d.node_id);
  try {
    m.forget_boot_ups();
    for (std::uint8_t id : nodes) m.nmt(fw::NmtCommand::kResetNode, id);
    m.wait_boot_up(nodes, c.boot_timeout_ns);
    for (int i = 0; i < c.size(); ++i) {
      if (c.check_drive_parameters) check_parameters(m, c, i);
      configure(m, c, i, skipped, log);
    }
    start_nodes(m, c, nodes);
    return skipped;
  } catch (...) {
    // Never leave a half-configured bus running: every node back to Pre-operational.
    for (std::uint8_t id : nodes) {
      try {
        m.nmt(fw::NmtCommand::kEnterPreOperational, id);
      } catch (const std::exception&) {
        // The original error is the one worth reporting.
      }
    }
    throw;
  }
}

}  // namespace dualv::drivers::canopen
