#pragma once
// A CANopen slave's PDO engine (CiA 301 7.2.2, 7.4.7.1, 7.5.2.35..38), like CANopenNode's
// CO_RPDO / CO_TPDO: the communication and mapping records of RPDO1..4 (1400h..1403h,
// 1600h..1603h) and TPDO1..4 (1800h..1803h, 1A00h..1A03h) in an ObjectDictionary, sub0 =
// the number of entries; mapped objects packed from / unpacked into the dictionary,
// dummy entries 0002h..0007h in RPDOs (the bytes are skipped). RPDO transmission types
// 0..240 are latched at the next SYNC, 254/255 act on reception; an RPDO shorter than its
// mapping is not processed (RpdoReceipt::too_short: the slave sends EMCY 8210h). TPDO types
// 1..240 are sent every n-th SYNC, 0/254/255 at a SYNC when their content changed and on
// their event timer (sub5, restarted by every transmission), never closer than the inhibit
// time (sub3, 100 us): a change inside it is sent when it ends (on_time). The RPDO event
// timer (1400h sub5) is deadline monitoring (expired_deadlines()).
// The engine knows neither NMT nor the application: its caller (sim/drive_emulator.cpp)
// calls it only in Operational and acts on what it reports. noexcept after set-up, no
// allocation; testable with frames alone (tests/sim/canopen/pdo_engine_test.cpp).
#include <array>
#include <cstdint>
#include <limits>

#include "firmware_if/can_frame.hpp"
#include "firmware_if/object_dictionary.hpp"
#include "sim/canopen/object_dictionary.hpp"

namespace dualv::sim::canopen {

inline constexpr std::uint8_t kPdosPerDirection = 4;  // RPDO1..4, TPDO1..4
inline constexpr std::uint64_t kPdoNever = std::numeric_limits<std::uint64_t>::max();

// What the application does behind the engine.
class PdoHooks {
 public:
  // A TPDO is due: send it (or drop it: the engine's timing counts it as sent).
  virtual void transmit(const fw::CanFrame& tpdo) noexcept = 0;
  // An RPDO stored a mapped object's value in `slot` (act on it, e.g. a controlword).
  virtual void written(int slot, std::uint64_t now_ns) noexcept = 0;
  // TPDO data is about to be sampled outside a SYNC (on_time): refresh live values.
  virtual void before_sample() noexcept = 0;

 protected:
  ~PdoHooks() = default;
};

struct PdoEngineOptions {
  bool fd = false;                    // CAN FD PDOs up to 64 bytes (CiA 1301); else 8
  bool refuse_dummy_mapping = false;  // a drive that cannot map 0002h..0007h (06040041h)
};

// One received frame, as the engine saw it.
struct RpdoReceipt {
  bool mine = false;       // a valid, mapped RPDO of this slave has the frame's COB-ID
  bool too_short = false;  // DLC below the mapping's length: not processed (EMCY 8210h)
  bool accepted = false;   // processed (latched for the next SYNC, or written now)
  std::uint8_t pdo = 0;    // 1..4 when accepted
};

class PdoEngine {
 public:
  // Set-up: the communication and mapping records with their power-on values (RPDO1 /
  // TPDO1 = firmware_if's kRpdo1Layout / kTpdo1Layout on 200h / 180h + node, valid,
  // transmission type 1; the others invalid, type 255, unmapped). Throws as
  // ObjectDictionary::add.
  static void add_objects(ObjectDictionary& od, std::uint8_t node);
  // True for an index of the records above.
  static bool is_parameter(std::uint16_t index) noexcept;

  void configure(const PdoEngineOptions& options) noexcept { options_ = options; }
  // Re-reads every record (after set-up, a write of a record, a reset); run-time state
  // (pending RPDOs, timers, last TPDO data) starts over.
  void rebuild(const ObjectDictionary& od) noexcept;
  // Re-reads the one PDO whose record `index` is (an SDO write of it: is_parameter(index));
  // only that PDO's run-time state starts over.
  void rebuild_pdo_of(const ObjectDictionary& od, std::uint16_t index) noexcept;
  // An SDO download of `value` to a record entry: 0 or the abort code (CiA 301 7.5.2.35:
  // the COB-ID may not change while valid; 7.5.2.36: mapping only while invalid, entries
  // only with sub0 = 0, sub0 = n checks every entry: 06020000h no object, 06040041h not
  // mappable / wrong length / dummy in a TPDO, 06040042h longer than the frame).
  std::uint32_t check_write(const ObjectDictionary& od, const fw::OdEntry& entry,
                            std::uint32_t value) const noexcept;

  // A received frame; processed only when `operational` (PDOs exist in NMT Operational
  // only), else only recognised (RpdoReceipt::mine).
  RpdoReceipt on_rpdo(const fw::CanFrame& frame, bool operational, ObjectDictionary& od,
                      PdoHooks& hooks, std::uint64_t now_ns) noexcept;
  // SYNC in Operational: the due TPDOs sampled from `od` and transmitted.
  void transmit_at_sync(const ObjectDictionary& od, PdoHooks& hooks, std::uint64_t now_ns) noexcept;
  // SYNC in Operational, after transmit_at_sync: the synchronous RPDOs received since the
  // previous SYNC written into `od`.
  void latch_at_sync(ObjectDictionary& od, PdoHooks& hooks, std::uint64_t now_ns) noexcept;
  // Timers in Operational: event-driven TPDOs (event timer, a change held by the inhibit time).
  void on_time(const ObjectDictionary& od, PdoHooks& hooks, std::uint64_t now_ns) noexcept;
  // RPDOs whose deadline (1400h sub5) has expired since their last reception; each is
  // reported once, then re-armed by its next reception.
  int expired_deadlines(std::uint64_t now_ns) noexcept;
  // Leaving Operational: pending RPDOs dropped, deadline monitoring stopped.
  void stop() noexcept;
  // The earliest time on_time (with `tpdos`: a slave that cannot send skips them) or
  // expired_deadlines has something to do, at least now_ns; kPdoNever: nothing scheduled.
  std::uint64_t next_due_ns(std::uint64_t now_ns, bool tpdos = true) const noexcept;

  // Whether RPDO / TPDO n (1..4) maps object `index` (any sub-index).
  bool maps(fw::od::PdoDirection d, std::uint8_t n, std::uint16_t index) const noexcept;
  bool valid(fw::od::PdoDirection d, std::uint8_t n) const noexcept { return pdo(d, n).valid; }
  // Mapped length in bytes.
  std::uint8_t length(fw::od::PdoDirection d, std::uint8_t n) const noexcept {
    return pdo(d, n).bytes;
  }

 private:
  using Data = std::array<std::uint8_t, fw::kFdMaxBytes>;
  struct MapRef {
    int slot = -1;  // -1: dummy entry (RPDO only)
    std::uint16_t index = 0;
    std::uint8_t bytes = 0;
  };
  struct Pdo {
    bool valid = false;
    std::uint16_t cob = 0;
    std::uint8_t type = 0;
    std::uint16_t event_ms = 0;
    std::uint64_t inhibit_ns = 0;  // TPDO: sub3 x 100 us
    std::uint8_t count = 0;
    std::array<MapRef, fw::od::kPdoMaxMappedObjects> map{};
    std::uint8_t bytes = 0;
    Data staged{};  // synchronous RPDO waiting for the next SYNC
    bool pending = false;
    std::uint8_t sync_count = 0;  // TPDO types 1..240
    Data last{};                  // TPDO: last sent
    bool sent_once = false;
    std::uint64_t next_event_ns = 0;
    std::uint64_t last_tx_ns = 0;
    bool change_pending = false;
    std::uint64_t last_rx_ns = 0;  // RPDO deadline
    bool deadline_armed = false;
  };
  const Pdo& pdo(fw::od::PdoDirection d, std::uint8_t n) const noexcept {
    return d == fw::od::PdoDirection::kRpdo ? rpdo_[n - 1u] : tpdo_[n - 1u];
  }
  void rebuild(const ObjectDictionary& od, fw::od::PdoDirection d, std::uint8_t n) noexcept;
  std::uint32_t check_mapping(const ObjectDictionary& od, fw::od::PdoDirection d, std::uint8_t n,
                              std::uint32_t count) const noexcept;
  static bool synchronous_tpdo(const Pdo& p) noexcept { return p.type >= 1 && p.type <= 240; }
  static bool inhibit_over(const Pdo& p, std::uint64_t now) noexcept;
  static Data sample(const ObjectDictionary& od, const Pdo& p) noexcept;
  void write_mapped(ObjectDictionary& od, const Pdo& p, const std::uint8_t* data, PdoHooks& hooks,
                    std::uint64_t now) noexcept;
  void transmit(Pdo& p, const Data& data, PdoHooks& hooks, std::uint64_t now) noexcept;

  PdoEngineOptions options_{};
  std::array<Pdo, kPdosPerDirection> rpdo_{};
  std::array<Pdo, kPdosPerDirection> tpdo_{};
};

}  // namespace dualv::sim::canopen
