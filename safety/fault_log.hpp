#pragma once
// The fault log: the real-time cycle records events in a fixed-capacity lock-free ring (no
// allocation, never blocks; when the ring is full the newest event is dropped and counted),
// and one non-RT thread drains it to a file (JSON lines) and/or hands the events on (the
// runtime converts FaultEvent into dualv_lcm::fault_event_t; it is plain, trivially
// copyable data for that reason).
#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <type_traits>

#include "common/spsc_queue.hpp"
#include "drivers/actuator_set.hpp"
#include "safety/fault.hpp"

namespace dualv::safety {

enum class EventKind : std::uint8_t {
  kFault = 0,      // a fault was detected (reaction: its table entry)
  kStopReached,    // SS1 reached standstill (or its time) and torque is off: STO
  kResetAccepted,  // every cause had cleared: the latch is clear, the loop holds disabled
  kResetRefused,   // a reset was requested while `blocking` causes were still active
  kArmed,          // a program start armed the safety filter
};
const char* to_string(EventKind k) noexcept;

struct FaultEvent {
  std::int64_t cycle = 0;    // control cycle of detection
  std::int64_t time_ns = 0;  // loop clock (simulated time in simulation) [ns]
  EventKind kind = EventKind::kFault;
  Fault fault = Fault::kCount;          // kFault: the cause; otherwise kCount
  Reaction reaction = Reaction::kWarn;  // what the filter does from this cycle on
  std::int16_t drive = -1;              // drive index concerned, -1 when none
  std::int32_t latency_cycles = 0;      // cycles between the first bad sample and detection
  double value = 0.0;                   // the measured value (e.g. 0.012 m) when it has one
  double limit = 0.0;                   // the limit it broke
  FaultSet blocking = 0;                // kResetRefused: the causes still active
  std::int16_t n = 0;
  std::array<double, drivers::kMaxDrives> torque{};  // torque sent in the detection cycle [N m]
};
static_assert(std::is_trivially_copyable_v<FaultEvent>);

// One JSON object on one line (non-RT: allocates).
std::string to_json(const FaultEvent& e);
// A short human-readable description, e.g. "tracking error 0.012 > 0.005 (SS1)".
std::string describe(const FaultEvent& e);
// The causes in `faults`, comma-separated ("e-stop (LCM), drive fault"); empty when none.
std::string describe_faults(FaultSet faults);

class FaultLog {
 public:
  static constexpr std::size_t kCapacity = 256;

  // Real-time producer: noexcept, O(1), no allocation. False (and counted) when full.
  bool record(const FaultEvent& e) noexcept {
    ++recorded_;
    return ring_.try_push(e);
  }
  // The one consumer thread.
  bool try_pop(FaultEvent& out) noexcept { return ring_.try_pop(out); }
  std::uint64_t recorded() const noexcept { return recorded_; }  // producer thread
  std::uint64_t dropped() const noexcept { return ring_.dropped(); }

 private:
  SpscQueue<FaultEvent, kCapacity> ring_;
  std::uint64_t recorded_ = 0;
};

// Non-RT: drains a FaultLog into a JSON-lines file (one event per line, flushed per drain).
class FaultLogWriter {
 public:
  // Opens (appends to) `path`; throws std::runtime_error when it cannot.
  explicit FaultLogWriter(const std::string& path);
  ~FaultLogWriter();
  FaultLogWriter(const FaultLogWriter&) = delete;
  FaultLogWriter& operator=(const FaultLogWriter&) = delete;
  // Writes every queued event; calls `also` for each when given (e.g. LCM publishing).
  // Returns the number written.
  template <typename Fn>
  std::size_t drain(FaultLog& log, Fn&& also) {
    std::size_t k = 0;
    FaultEvent e;
    while (log.try_pop(e)) {
      write(e);
      also(e);
      ++k;
    }
    if (k) std::fflush(file_);
    return k;
  }
  std::size_t drain(FaultLog& log) {
    return drain(log, [](const FaultEvent&) {});
  }

 private:
  void write(const FaultEvent& e);
  std::FILE* file_ = nullptr;
};

}  // namespace dualv::safety
