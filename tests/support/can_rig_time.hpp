#pragma once
// Simulated time for a CANopen master on the in-process CAN rig (sim/in_process_can_rig.hpp):
// the master's clock is the rig's, and its set-up waits (boot, SDO, CiA 402 transitions) run
// the drive emulators in simulated time instead of sleeping, so tests and the bus attacker
// (fuzz/bus_attack_fuzz.cpp) are deterministic.
#include <algorithm>
#include <cstdint>

#include "drivers/canopen/clock.hpp"
#include "drivers/canopen/waiter.hpp"
#include "sim/in_process_can_rig.hpp"

namespace dualv::test {

class RigClock final : public drivers::canopen::Clock {
 public:
  explicit RigClock(const sim::InProcessCanRig& rig) : rig_(rig) {}
  std::uint64_t now_ns() const noexcept override { return rig_.now_ns(); }

 private:
  const sim::InProcessCanRig& rig_;
};

class RigWaiter final : public drivers::canopen::Waiter {
 public:
  static constexpr std::uint64_t kStepNs = 100'000;  // 0.1 ms: the emulator's answer time
  // At most one SocketCanWaiter slice (drivers/canopen/waiter.hpp) per wait: the master's
  // heartbeat keeps going during long waits, as on a real bus.
  static constexpr std::uint64_t kSliceNs = 5'000'000;

  explicit RigWaiter(sim::InProcessCanRig& rig) : rig_(rig) {}
  // As SocketCanWaiter: returns when a frame may be ready or at the deadline. The emulator
  // answers the frames it received within 0.1 ms; otherwise nothing reaches the master
  // before the emulator's next timer (DriveEmulator::next_due_ns: heartbeats, consumer
  // timeouts, event TPDOs), so simulated time jumps there (capped by a slice) instead of
  // running the emulator's timers every 0.1 ms of a boot's long waits.
  void wait_until(std::uint64_t deadline_ns) override {
    const std::uint64_t now = rig_.now_ns();
    const bool answered = rig_.exchange() > 0;
    if (deadline_ns <= now) return;
    const std::uint64_t due = rig_.emulator().next_due_ns(now);
    const std::uint64_t until =
        answered || due <= now ? now + kStepNs : std::min(due, now + kSliceNs);
    rig_.advance(std::min(until, deadline_ns) - now);
  }

 private:
  sim::InProcessCanRig& rig_;
};

}  // namespace dualv::test
