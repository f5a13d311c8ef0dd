#include "drivers/canopen/eds_check.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <optional>
#include <set>

#include "drivers/canopen/boot.hpp"
#include "firmware_if/cia402.hpp"
#include "firmware_if/pdo.hpp"

namespace dualv::drivers::canopen {

namespace {

namespace eds = fw::eds;

bool writable(fw::Access a) { return a == fw::Access::kRw || a == fw::Access::kWo; }
bool readable(fw::Access a) { return a != fw::Access::kWo; }

// firmware_if's entry for an (index, sub), for the name and type of a mapped object.
std::optional<fw::OdEntry> known_entry(std::uint16_t index, std::uint8_t sub) {
  for (const fw::OdEntry& e : fw::od::kAll)
    if (e.same_object(index, sub)) return e;
  return std::nullopt;
}

std::string what(std::uint16_t index, std::uint8_t sub) {
  const auto e = known_entry(index, sub);
  return e ? describe(*e) : fmt::format("{:04X}h sub{}", index, sub);
}

// What skipping each non-mandatory object means (drivers/canopen/README.md "Boot objects");
// the rules that keep it safe are enforced when the `can:` section is loaded
// (drivers/canopen_config.cpp check_objects) and re-checked below against the EDS.
const char* consequence(const std::string& key) {
  if (key == "abort_connection")
    return "6007h absent: the drive's own reaction to a lost host applies; its heartbeat "
           "consumer 1016h (required) is what stops it when the host is gone";
  if (key == "consumer_heartbeat")
    return "1016h absent: the drive does not watch the host's heartbeat; only the RPDO "
           "deadline (1400h sub5, can.rpdo_deadline) stops it when the host is gone";
  if (key == "digital_inputs")
    return "60FDh TPDO2 absent: software does not see the e-stop circuit (the hardwired STO "
           "still stops the drive)";
  if (key == "quick_stop" || key == "fault_reaction")
    return "the drive keeps its default option code (check it in its manual)";
  if (key == "cycle_period") return "1006h absent: the drive cannot monitor the SYNC period";
  if (key == "interpolation_period")
    return "60C2h absent: the drive uses its own default interpolation period for cyclic "
           "synchronous torque";
  return "";
}

struct Checker {
  const eds::Eds& eds;
  const CanConfig& c;
  int drive;
  std::uint8_t node;
  EdsCheckReport r;
  // Objects (can.objects keys) whose remaining writes are not looked at: skipped, or a
  // required one already reported missing (boot stops at its first absent write).
  std::set<std::string> skipped_keys;
  std::set<std::pair<std::uint16_t, std::uint8_t>> mapped_done;

  // A missing object: skipped when its policy is optional, else a problem.
  void missing(const ConfigWrite* w, const std::string& text) {
    if (w != nullptr && w->object != nullptr && w->policy == ObjectPolicy::kOptional) {
      if (skipped_keys.insert(w->object).second) {
        r.skipped.push_back(
            fmt::format("node {}: {} skipped (optional): {}", node, w->object, text));
        if (const char* why = consequence(w->object); *why != '\0')
          r.notes.push_back(fmt::format("node {}: {}", node, why));
      }
      return;
    }
    if (w != nullptr && w->object != nullptr && skipped_keys.insert(w->object).second)
      r.problems.push_back(fmt::format(
          "node {}: {} (can.objects.{} is required; make it optional to boot without it)", node,
          text, w->object));
    else if (w == nullptr || w->object == nullptr)
      r.problems.push_back(fmt::format("node {}: {}", node, text));
  }

  // (index, sub) absent from an EDS that has the object: the EDS describes a record without
  // a sub-index the configuration uses. A problem whatever the object's policy (an optional
  // object may be absent as a whole, not in part), named by file, line, object and sub-index.
  // False when the object itself is absent.
  bool sub_index_missing(std::uint16_t index, std::uint8_t sub, const std::string& entry,
                         const std::string& role) {
    const eds::EdsObject* o = eds.object(index);
    if (o == nullptr) return false;
    r.problems.push_back(fmt::format(
        "node {}: {}:{}: object {:04X}h has no sub-index {} ({}, {}): the EDS describes the "
        "object without an entry the configuration needs",
        node, eds.file, o->line, index, sub, entry, role));
    return true;
  }

  bool skipping(const ConfigWrite& w) const {
    return w.object != nullptr && skipped_keys.count(w.object) != 0;
  }

  // The EDS entry of a firmware_if entry, its type checked; nullptr when absent.
  const eds::EdsEntry* find(const fw::OdEntry& want, const ConfigWrite* w, const char* role) {
    const eds::EdsEntry* e = eds.entry(want.index, want.subindex);
    if (e == nullptr) {
      const std::string why = w != nullptr && w->object != nullptr
                                  ? fmt::format("{}: can.objects.{}", role, w->object)
                                  : std::string(role);
      if (sub_index_missing(want.index, want.subindex, describe(want), why)) return nullptr;
      missing(w, fmt::format("{} is not in the EDS ({})", describe(want), role));
      return nullptr;
    }
    if (e->type() != want.type)
      r.problems.push_back(fmt::format("node {}: {} is {} in the EDS (line {}), the stack uses {}",
                                       node, describe(want), eds::data_type_name(e->data_type),
                                       e->line,
                                       eds::data_type_name(static_cast<std::uint16_t>(want.type))));
    return e;
  }

  void check_write(const ConfigWrite& w) {
    if (skipping(w)) return;
    const eds::EdsEntry* e = find(w.entry, &w, "boot writes it");
    if (e == nullptr) return;
    if (!writable(e->access))
      r.problems.push_back(
          fmt::format("node {}: {} is {} in the EDS (line {}): boot writes it ({})", node,
                      describe(w.entry), e->access_text, e->line, w.why));
    const bool rpdo_map = w.entry.index >= fw::od::kRpdoMappingBase && w.entry.index < 0x1800;
    const bool tpdo_map = w.entry.index >= fw::od::kTpdoMappingBase && w.entry.index < 0x1C00;
    if ((rpdo_map || tpdo_map) && w.entry.subindex != 0) check_mapped(w, rpdo_map);
  }

  // An object a PDO carries (CiA 301 7.5.2.36 / 7.5.2.38).
  void check_mapped(const ConfigWrite& w, bool rpdo) {
    const fw::PdoMapEntry m = fw::decode_mapping(w.value);
    if (fw::is_dummy(m)) return;
    if (!mapped_done.insert({m.index, m.subindex}).second) return;
    const char* dir = rpdo ? "an RPDO" : "a TPDO";
    const eds::EdsEntry* e = eds.entry(m.index, m.subindex);
    if (e == nullptr) {
      if (!sub_index_missing(m.index, m.subindex, what(m.index, m.subindex),
                             fmt::format("mapped into {} at {:04X}h", dir, w.entry.index)))
        missing(&w, fmt::format("{} (mapped into {} at {:04X}h) is not in the EDS",
                                what(m.index, m.subindex), dir, w.entry.index));
      return;
    }
    if (const auto k = known_entry(m.index, m.subindex); k && e->type() != k->type)
      r.problems.push_back(fmt::format("node {}: {} is {} in the EDS (line {}), the stack uses {}",
                                       node, describe(*k), eds::data_type_name(e->data_type),
                                       e->line,
                                       eds::data_type_name(static_cast<std::uint16_t>(k->type))));
    if (!e->pdo_mappable)
      r.problems.push_back(
          fmt::format("node {}: {} is not PDO-mappable in the EDS (line {}: PDOMapping=0) but {} "
                      "carries it",
                      node, what(m.index, m.subindex), e->line, dir));
    if (e->type() && 8u * fw::size_of(*e->type()) != m.bits)
      r.problems.push_back(fmt::format("node {}: {} is {} bits in the EDS (line {}), mapped as {}",
                                       node, what(m.index, m.subindex),
                                       8u * fw::size_of(*e->type()), e->line, m.bits));
    if (rpdo ? !writable(e->access) : !readable(e->access))
      r.problems.push_back(
          fmt::format("node {}: {} is {} in the EDS (line {}): {} needs it {}", node,
                      what(m.index, m.subindex), e->access_text, e->line, dir,
                      rpdo ? "writable (rw, rww, wo)" : "readable (ro, rw, rwr, const)"));
  }

  void check_reads() {
    if (!c.check_drive_parameters) return;
    for (const fw::OdEntry& want : kParameterReads) {
      const eds::EdsEntry* e = find(want, nullptr, "boot reads it: can.check_drive_parameters");
      if (e == nullptr) continue;
      if (!readable(e->access))
        r.problems.push_back(fmt::format("node {}: {} is wo in the EDS (line {}): boot reads it",
                                         node, describe(want), e->line));
      const auto v = eds::default_value(*e, node);
      if (!v) continue;
      if (want.same_object(fw::od::kDeviceType.index, 0) &&
          (*v & 0xFFFFu) != fw::od::kDeviceProfileCia402)
        r.problems.push_back(
            fmt::format("node {}: 1000h DefaultValue {:08X}h (line {}) is not a CiA 402 device",
                        node, *v, e->line));
      if (want.same_object(fw::od::kSupportedDriveModes.index, 0) &&
          (*v & fw::supported_mode_bit(fw::ModeOfOperation::kCyclicSyncTorque)) == 0)
        r.problems.push_back(fmt::format(
            "node {}: 6502h DefaultValue {:08X}h (line {}) lacks cyclic synchronous torque (bit 9)",
            node, *v, e->line));
    }
  }

  // The safety rules of drivers/canopen_config.cpp check_objects, on what the EDS has: a drive
  // lacking both 6007h and 1016h would not stop when the host is gone.
  void check_consequences() {
    const bool no_abort = eds.object(fw::od::kAbortConnectionOption.index) == nullptr;
    const bool no_hb = eds.entry(fw::od::consumer_heartbeat(1).index, 1) == nullptr;
    if (no_abort && no_hb)
      r.problems.push_back(fmt::format(
          "node {}: the EDS has neither 6007h nor 1016h sub1: nothing makes the drive stop when "
          "the host is gone",
          node));
    if (no_hb && c.rpdo_deadline_ns == 0)
      r.problems.push_back(fmt::format(
          "node {}: the EDS has no 1016h sub1 and can.rpdo_deadline is 0: nothing makes the drive "
          "stop when the host is gone",
          node));
  }
};

}  // namespace

EdsCheckReport check_eds(const fw::eds::Eds& eds, const CanConfig& config, int drive) {
  Checker k{eds, config, drive, config.drives.at(static_cast<std::size_t>(drive)).node_id,
            {},  {},     {}};
  k.r.node = k.node;
  k.check_reads();
  for (const ConfigWrite& w : boot_writes(config, drive)) k.check_write(w);
  k.check_consequences();
  return k.r;
}

}  // namespace dualv::drivers::canopen
