#include "sim/canopen/pdo_engine.hpp"

#include <algorithm>

#include "firmware_if/byte_order.hpp"
#include "firmware_if/cob_id.hpp"
#include "firmware_if/pdo.hpp"
#include "firmware_if/sdo.hpp"

namespace dualv::sim::canopen {

namespace {

using fw::od::PdoDirection;

constexpr std::uint32_t kNoAbort = 0;
constexpr std::uint32_t abort_value(fw::SdoAbortCode c) noexcept {
  return static_cast<std::uint32_t>(c);
}

}  // namespace

void PdoEngine::add_objects(ObjectDictionary& od, std::uint8_t node) {
  namespace fo = fw::od;
  for (std::uint8_t n = 1; n <= kPdosPerDirection; ++n) {
    for (PdoDirection d : {PdoDirection::kRpdo, PdoDirection::kTpdo}) {
      const bool rx = d == PdoDirection::kRpdo;
      const fw::Function f = rx ? fw::rpdo_function(n) : fw::tpdo_function(n);
      od.add(fo::pdo_communication_count(d, n), fo::kPdoSubEventTimer);
      od.add(fo::pdo_cob_id(d, n), fw::pdo_cob_id_value(fw::cob_id(f, node), n == 1));
      od.add(fo::pdo_transmission_type(d, n),
             n == 1 ? fw::kTransmissionSyncEvery : fw::kTransmissionEventProfile);
      od.add(fo::pdo_inhibit_time(d, n), 0);
      od.add(fo::pdo_event_timer(d, n), 0);
      const fw::PdoLayout& l = rx ? fw::kRpdo1Layout : fw::kTpdo1Layout;
      od.add(fo::pdo_mapping_count(d, n), n == 1 ? l.count : 0);
      for (std::uint8_t s = 1; s <= fo::kPdoMaxMappedObjects; ++s)
        od.add(fo::pdo_mapping_entry(d, n, s),
               (n == 1 && s <= l.count) ? fw::encode_mapping(l.entries[s - 1u]) : 0u);
    }
  }
}

bool PdoEngine::is_parameter(std::uint16_t index) noexcept {
  namespace fo = fw::od;
  for (std::uint16_t base : {fo::kRpdoCommunicationBase, fo::kRpdoMappingBase,
                             fo::kTpdoCommunicationBase, fo::kTpdoMappingBase})
    if (index >= base && index < base + kPdosPerDirection) return true;
  return false;
}

void PdoEngine::rebuild(const ObjectDictionary& od) noexcept {
  for (std::uint8_t n = 1; n <= kPdosPerDirection; ++n) {
    rebuild(od, PdoDirection::kRpdo, n);
    rebuild(od, PdoDirection::kTpdo, n);
  }
}

void PdoEngine::rebuild_pdo_of(const ObjectDictionary& od, std::uint16_t index) noexcept {
  for (PdoDirection d : {PdoDirection::kRpdo, PdoDirection::kTpdo})
    for (std::uint8_t n = 1; n <= kPdosPerDirection; ++n)
      if (index == fw::od::pdo_communication_index(d, n) ||
          index == fw::od::pdo_mapping_index(d, n))
        rebuild(od, d, n);
}

void PdoEngine::rebuild(const ObjectDictionary& od, PdoDirection d, std::uint8_t n) noexcept {
  namespace fo = fw::od;
  const bool rx = d == PdoDirection::kRpdo;
  Pdo& p = rx ? rpdo_[n - 1u] : tpdo_[n - 1u];
  p = Pdo{};
  const std::uint32_t cob = od.u(od.find(fo::pdo_cob_id(d, n)));
  p.valid = (cob & fw::kPdoCobIdInvalid) == 0;
  p.cob = static_cast<std::uint16_t>(cob & fw::kMaxStandardId);
  p.type = static_cast<std::uint8_t>(od.u(od.find(fo::pdo_transmission_type(d, n))));
  p.event_ms = static_cast<std::uint16_t>(od.u(od.find(fo::pdo_event_timer(d, n))));
  if (!rx) p.inhibit_ns = od.u(od.find(fo::pdo_inhibit_time(d, n))) * 100'000ull;
  const auto count = static_cast<std::uint8_t>(std::min<std::uint32_t>(
      od.u(od.find(fo::pdo_mapping_count(d, n))), fo::kPdoMaxMappedObjects));
  std::uint32_t bits = 0;
  for (std::uint8_t s = 1; s <= count; ++s) {
    const fw::PdoMapEntry e = fw::decode_mapping(od.u(od.find(fo::pdo_mapping_entry(d, n, s))));
    MapRef m;
    m.bytes = static_cast<std::uint8_t>(e.bits / 8);
    m.index = e.index;
    if (!fw::is_dummy(e)) {
      m.slot = od.find(e.index, e.subindex);
      if (m.slot < 0) return;  // checked when sub0 was written; never from defaults
    }
    bits += e.bits;
    p.map[s - 1u] = m;
  }
  p.count = count;
  p.bytes = static_cast<std::uint8_t>((bits + 7) / 8);
}

std::uint32_t PdoEngine::check_mapping(const ObjectDictionary& od, PdoDirection d, std::uint8_t n,
                                       std::uint32_t count) const noexcept {
  const bool rx = d == PdoDirection::kRpdo;
  if (count > fw::od::kPdoMaxMappedObjects) return abort_value(fw::SdoAbortCode::kMappingTooLong);
  std::uint32_t bits = 0;
  for (std::uint8_t s = 1; s <= count; ++s) {
    const fw::PdoMapEntry e = fw::decode_mapping(od.u(od.find(fw::od::pdo_mapping_entry(d, n, s))));
    if (fw::is_dummy(e)) {
      // Dummies only in RPDOs, with the type's own length (CiA 301 7.4.7.1).
      const auto t = static_cast<fw::DataType>(e.index);
      if (!rx || e.bits != 8 * fw::size_of(t))
        return abort_value(fw::SdoAbortCode::kCannotBeMapped);
    } else {
      const int slot = od.find(e.index, e.subindex);
      if (slot < 0) return abort_value(fw::SdoAbortCode::kObjectDoesNotExist);
      const fw::OdEntry& o = od.entry(slot);
      const bool writable = o.access == fw::Access::kRw || o.access == fw::Access::kWo;
      const bool readable = o.access != fw::Access::kWo;
      if (!o.pdo_mappable || e.bits != o.bits() || (rx && !writable) || (!rx && !readable))
        return abort_value(fw::SdoAbortCode::kCannotBeMapped);
    }
    bits += e.bits;
  }
  // A classic PDO ends at 8 bytes; a CAN FD drive's at 64 (CiA 1301).
  if (bits > 8u * (options_.fd ? fw::kFdMaxBytes : fw::kClassicMaxBytes))
    return abort_value(fw::SdoAbortCode::kMappingTooLong);
  return kNoAbort;
}

std::uint32_t PdoEngine::check_write(const ObjectDictionary& od, const fw::OdEntry& e,
                                     std::uint32_t v) const noexcept {
  namespace fo = fw::od;
  if (!is_parameter(e.index)) return kNoAbort;
  const bool comm = e.index < fo::kRpdoMappingBase ||
                    (e.index >= fo::kTpdoCommunicationBase && e.index < fo::kTpdoMappingBase);
  const bool rx = e.index < fo::kTpdoCommunicationBase;
  const PdoDirection d = rx ? PdoDirection::kRpdo : PdoDirection::kTpdo;
  const std::uint16_t base = comm ? (rx ? fo::kRpdoCommunicationBase : fo::kTpdoCommunicationBase)
                                  : (rx ? fo::kRpdoMappingBase : fo::kTpdoMappingBase);
  const auto n = static_cast<std::uint8_t>(e.index - base + 1);
  const Pdo& p = pdo(d, n);
  if (comm) {
    if (e.subindex == fo::kPdoSubCobId) {
      if (v & (1u << 29)) return abort_value(fw::SdoAbortCode::kInvalidValue);  // 29-bit id
      const bool new_valid = (v & fw::kPdoCobIdInvalid) == 0;
      // CiA 301 7.5.2.35: the COB-ID may not change while the PDO stays valid.
      if (p.valid && new_valid && (v & fw::kMaxStandardId) != p.cob)
        return abort_value(fw::SdoAbortCode::kInvalidValue);
      return kNoAbort;
    }
    if (e.subindex == fo::kPdoSubTransmissionType)
      return (v <= 240 || v >= fw::kTransmissionEventManufacturer)
                 ? kNoAbort
                 : abort_value(fw::SdoAbortCode::kInvalidValue);
    return kNoAbort;
  }
  // Mapping (CiA 301 7.5.2.36): only while the PDO is not valid; entries only with sub0 = 0.
  if (p.valid) return abort_value(fw::SdoAbortCode::kUnsupportedAccess);
  if (e.subindex == 0) return v == 0 ? kNoAbort : check_mapping(od, d, n, v);
  if (od.u(od.find(fo::pdo_mapping_count(d, n))) != 0)
    return abort_value(fw::SdoAbortCode::kUnsupportedAccess);
  if (options_.refuse_dummy_mapping && fw::is_dummy(fw::decode_mapping(v)))
    return abort_value(fw::SdoAbortCode::kCannotBeMapped);
  return kNoAbort;
}

bool PdoEngine::maps(PdoDirection d, std::uint8_t n, std::uint16_t index) const noexcept {
  const Pdo& p = pdo(d, n);
  for (std::uint8_t k = 0; k < p.count; ++k)
    if (p.map[k].slot >= 0 && p.map[k].index == index) return true;
  return false;
}

void PdoEngine::write_mapped(ObjectDictionary& od, const Pdo& p, const std::uint8_t* data,
                             PdoHooks& hooks, std::uint64_t now) noexcept {
  std::size_t off = 0;
  for (std::uint8_t k = 0; k < p.count; ++k) {
    const MapRef& m = p.map[k];
    if (m.slot >= 0) {
      od.set(m.slot, fw::get_uint_le(data + off, m.bytes));
      hooks.written(m.slot, now);
    }
    off += m.bytes;  // a dummy entry's bytes are skipped
  }
}

RpdoReceipt PdoEngine::on_rpdo(const fw::CanFrame& frame, bool operational, ObjectDictionary& od,
                               PdoHooks& hooks, std::uint64_t now) noexcept {
  RpdoReceipt r;
  for (std::uint8_t n = 1; n <= kPdosPerDirection; ++n) {
    Pdo& p = rpdo_[n - 1u];
    if (!p.valid || p.count == 0 || p.cob != frame.id) continue;
    if (frame.fd && !options_.fd) continue;  // a classic drive cannot receive an FD frame
    r.mine = true;
    if (!operational) continue;  // PDOs only in Operational
    if (frame.dlc < p.bytes) {
      r.too_short = true;  // not processed (CiA 301 7.2.2.2); the slave sends EMCY 8210h
      continue;
    }
    r.accepted = true;
    r.pdo = n;
    p.last_rx_ns = now;
    p.deadline_armed = true;
    if (p.type <= 240) {  // synchronous: acted upon at the next SYNC (CiA 301 7.2.2.2)
      p.staged = frame.data;
      p.pending = true;
    } else {
      write_mapped(od, p, frame.data.data(), hooks, now);
    }
  }
  return r;
}

bool PdoEngine::inhibit_over(const Pdo& p, std::uint64_t now) noexcept {
  return !p.sent_once || p.inhibit_ns == 0 || now - p.last_tx_ns >= p.inhibit_ns;
}

PdoEngine::Data PdoEngine::sample(const ObjectDictionary& od, const Pdo& p) noexcept {
  Data data{};
  std::size_t off = 0;
  for (std::uint8_t k = 0; k < p.count; ++k) {
    const MapRef& m = p.map[k];
    std::array<std::uint8_t, 4> b{};
    fw::put_u32_le(b.data(), od.u(m.slot));
    for (std::uint8_t j = 0; j < m.bytes && off + j < data.size(); ++j) data[off + j] = b[j];
    off += m.bytes;
  }
  return data;
}

void PdoEngine::transmit(Pdo& p, const Data& data, PdoHooks& hooks, std::uint64_t now) noexcept {
  p.last = data;
  p.sent_once = true;
  p.change_pending = false;
  p.last_tx_ns = now;
  if (p.event_ms != 0) p.next_event_ns = now + static_cast<std::uint64_t>(p.event_ms) * 1'000'000u;
  // On a CAN FD drive every TPDO is an FD frame with BRS (its size rounded up to a DLC size).
  fw::CanFrame f = fw::data_frame(p.cob, p.bytes, options_.fd);
  f.data = data;
  hooks.transmit(f);
}

void PdoEngine::transmit_at_sync(const ObjectDictionary& od, PdoHooks& hooks,
                                 std::uint64_t now) noexcept {
  for (Pdo& p : tpdo_) {
    if (!p.valid || p.count == 0) continue;
    const Data data = sample(od, p);
    if (synchronous_tpdo(p)) {
      if (++p.sync_count >= p.type) {
        p.sync_count = 0;
        transmit(p, data, hooks, now);
      }
    } else if (!p.sent_once || data != p.last) {
      if (inhibit_over(p, now))
        transmit(p, data, hooks, now);
      else
        p.change_pending = true;  // sent by on_time when the inhibit time ends
    }
  }
}

void PdoEngine::latch_at_sync(ObjectDictionary& od, PdoHooks& hooks, std::uint64_t now) noexcept {
  for (Pdo& p : rpdo_) {
    if (!p.pending) continue;
    p.pending = false;
    write_mapped(od, p, p.staged.data(), hooks, now);
  }
}

void PdoEngine::on_time(const ObjectDictionary& od, PdoHooks& hooks, std::uint64_t now) noexcept {
  for (Pdo& p : tpdo_) {
    if (!p.valid || p.count == 0 || synchronous_tpdo(p)) continue;
    const bool timer = p.event_ms != 0 && now >= p.next_event_ns;
    if (!(timer || p.change_pending) || !inhibit_over(p, now)) continue;
    hooks.before_sample();
    const Data data = sample(od, p);
    if (timer || data != p.last)
      transmit(p, data, hooks, now);
    else
      p.change_pending = false;  // changed back within the inhibit time: nothing new
  }
}

int PdoEngine::expired_deadlines(std::uint64_t now) noexcept {
  int expired = 0;
  for (Pdo& p : rpdo_) {
    if (!p.valid || p.event_ms == 0 || !p.deadline_armed) continue;
    if (now - p.last_rx_ns < static_cast<std::uint64_t>(p.event_ms) * 1'000'000u) continue;
    p.deadline_armed = false;
    ++expired;
  }
  return expired;
}

void PdoEngine::stop() noexcept {
  for (Pdo& p : rpdo_) {
    p.pending = false;
    p.deadline_armed = false;
  }
}

std::uint64_t PdoEngine::next_due_ns(std::uint64_t now, bool tpdos) const noexcept {
  std::uint64_t due = kPdoNever;
  for (const Pdo& p : rpdo_)
    if (p.valid && p.event_ms != 0 && p.deadline_armed)
      due = std::min(due, p.last_rx_ns + static_cast<std::uint64_t>(p.event_ms) * 1'000'000u);
  for (const Pdo& p : tpdo_) {
    if (!tpdos || !p.valid || p.count == 0 || synchronous_tpdo(p)) continue;
    std::uint64_t t = p.change_pending ? now : kPdoNever;
    if (p.event_ms != 0) t = std::min(t, p.next_event_ns);
    if (t != kPdoNever && p.sent_once && p.inhibit_ns != 0)
      t = std::max(t, p.last_tx_ns + p.inhibit_ns);
    due = std::min(due, t);
  }
  return due == kPdoNever ? due : std::max(due, now);
}

}  // namespace dualv::sim::canopen
