#pragma once
// Simulated time for a CANopen master on the in-process CAN rig (sim/in_process_can_rig.hpp):
// the master's clock is the rig's, and its set-up waits (boot, SDO, CiA 402 transitions) run
// the drive emulators in 0.1 ms steps of simulated time instead of sleeping, so tests and the
// bus attacker (fuzz/bus_attack_fuzz.cpp) are deterministic.
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
  static constexpr std::uint64_t kStepNs = 100'000;  // 0.1 ms of simulated time per wait

  explicit RigWaiter(sim::InProcessCanRig& rig) : rig_(rig) {}
  void wait_until(std::uint64_t deadline_ns) override {
    const std::uint64_t now = rig_.now_ns();
    if (deadline_ns <= now) {
      rig_.exchange();
      return;
    }
    rig_.step(std::min<std::uint64_t>(kStepNs, deadline_ns - now));
  }

 private:
  sim::InProcessCanRig& rig_;
};

}  // namespace dualv::test
