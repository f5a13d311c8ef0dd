#pragma once
// The stop latch: every fault that stopped the machine stays latched until an explicit
// reset, and a reset is accepted only once every latched cause has cleared (Clearing in
// fault.hpp). A reset never restarts motion: the control loop then holds with zero torque
// and disabled drives until a program is started again (IEC 60204-1 9.2.5.4.2: resetting
// the emergency stop shall not by itself restart the machine).
//
// Other threads (the LCM command channel, a signal handler, the operator console) only
// post requests: request_stop() and request_reset() are noexcept, lock-free and
// async-signal-safe (a fetch_or / store on a lock-free std::atomic). The real-time cycle
// takes them with take_requests() and owns everything else; nothing here allocates.
#include <atomic>
#include <cstdint>

#include "safety/fault.hpp"

namespace dualv::safety {

// Where an external stop request comes from (each maps to one Fault).
enum class StopSource : std::uint8_t { kLcm = 0, kSignal, kCli };
constexpr Fault fault_of(StopSource s) noexcept {
  switch (s) {
    case StopSource::kLcm:
      return Fault::kEstopLcm;
    case StopSource::kSignal:
      return Fault::kEstopSignal;
    case StopSource::kCli:
      return Fault::kEstopCli;
  }
  return Fault::kEstopCli;
}

class EstopLatch {
 public:
  // --- any thread, async-signal-safe --------------------------------------------------
  void request_stop(StopSource source) noexcept {
    pending_.fetch_or(bit(fault_of(source)), std::memory_order_release);
  }
  void request_reset() noexcept { reset_pending_.store(true, std::memory_order_release); }
  static constexpr bool kLockFree =
      std::atomic<FaultSet>::is_always_lock_free && std::atomic<bool>::is_always_lock_free;

  // --- the real-time cycle only -------------------------------------------------------
  // Stop requests posted since the last call (cleared by taking them).
  FaultSet take_stop_requests() noexcept { return pending_.exchange(0, std::memory_order_acq_rel); }
  bool take_reset_request() noexcept {
    return reset_pending_.exchange(false, std::memory_order_acq_rel);
  }

  // Latches `faults`; returns the ones that were not latched before.
  FaultSet latch(FaultSet faults) noexcept {
    const FaultSet fresh = faults & ~latched_;
    latched_ |= faults;
    return fresh;
  }
  FaultSet latched() const noexcept { return latched_; }
  bool any() const noexcept { return latched_ != 0; }

  // Latched causes that keep a reset from being accepted: the condition causes whose
  // condition is still true in `active_now` (the cycle's evaluation of this cycle).
  FaultSet blocking(FaultSet active_now) const noexcept {
    FaultSet b = 0;
    for (int i = 0; i < kFaultCount; ++i) {
      const FaultSet m = FaultSet{1} << i;
      if ((latched_ & m) &&
          kFaultTable[static_cast<std::size_t>(i)].clearing == Clearing::kCondition &&
          (active_now & m))
        b |= m;
    }
    return b;
  }
  // Clears every cause when none blocks; returns the blocking set (0: reset accepted).
  FaultSet try_reset(FaultSet active_now) noexcept {
    const FaultSet b = blocking(active_now);
    if (b == 0) latched_ = 0;
    return b;
  }

 private:
  std::atomic<FaultSet> pending_{0};
  std::atomic<bool> reset_pending_{false};
  FaultSet latched_ = 0;  // RT thread only
};

static_assert(EstopLatch::kLockFree, "stop requests must be lock-free (signal handlers post them)");

}  // namespace dualv::safety
