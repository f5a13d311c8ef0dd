#pragma once
// The full stack over CAN frames, in one process, without sleeping: an InProcessHub whose
// endpoint 0 is the master's (drivers/canopen*: hand it master_bus()), endpoint 1 the drive
// emulator's, endpoint 2 a monitor that receives every frame both sides send (for tests
// that check the wire, e.g. "no target torque above the limit in any captured frame").
// The plant behind the emulator is built with emulator_plant_config() (see
// sim/drive_emulator.hpp for the timing model).
//
// Lock-step with simulated time, one control cycle:
//   master cycle at now_ns()   (the master reads what it received, sends RPDOs and SYNC)
//   rig.step(period_ns)        the emulator receives those frames at now_ns() and answers
//                              (TPDOs sampled at that SYNC, SDO responses, ...), then time
//                              advances by period_ns and the emulator's timers run at the
//                              new time (heartbeats, consumer timeouts, RPDO deadlines)
// so the master's next cycle finds the TPDOs of its previous SYNC in its queue. Finer
// steps (step(100'000) x 10 per cycle) give timers 0.1 ms resolution. Every frame is
// stamped with the hub's clock. Nothing here allocates after construction; step() is
// noexcept.
#include <cstdint>
#include <memory>

#include "drivers/can/in_process_bus.hpp"
#include "firmware_if/can_config.hpp"
#include "sim/drive_emulator.hpp"
#include "sim/plant.hpp"

namespace dualv::sim {

class InProcessCanRig {
 public:
  static constexpr std::size_t kMasterEndpoint = 0;
  static constexpr std::size_t kEmulatorEndpoint = 1;
  static constexpr std::size_t kMonitorEndpoint = 2;

  // `model` is the controller's model (the plant integrates its "true" variant),
  // `plant_config` the `plant:` section as loaded (emulator_plant_config() is applied here),
  // `emulator` e.g. emulator_config_from(load_can_config_file(...)). queue_capacity: frames
  // per endpoint receive ring (a full ring drops new frames for that endpoint, counted in
  // its rx_overruns: drain the monitor every cycle when checking the wire). Throws
  // std::invalid_argument (emulator set-up) with what to fix.
  InProcessCanRig(const model::Model& model, const PlantConfig& plant_config,
                  const DriveEmulatorConfig& emulator, std::size_t queue_capacity = 1024);
  // Same, from the `can:` section.
  InProcessCanRig(const model::Model& model, const PlantConfig& plant_config,
                  const fw::CanConfig& can, std::size_t queue_capacity = 1024);

  drivers::InProcessBus& master_bus() noexcept { return *master_; }
  drivers::InProcessBus& monitor_bus() noexcept { return *monitor_; }
  drivers::InProcessHub& hub() noexcept { return hub_; }
  DriveEmulator& emulator() noexcept { return *emulator_; }
  Plant& plant() noexcept { return *plant_; }
  std::uint64_t now_ns() const noexcept { return hub_.now_ns(); }

  // The emulator handles every frame sent so far at now_ns() (and runs its timers there).
  std::size_t exchange() noexcept { return emulator_->poll(hub_.now_ns()); }
  // exchange(), then the clock advances by dt_ns and the emulator's timers run.
  void step(std::uint64_t dt_ns) noexcept {
    exchange();
    hub_.advance_ns(dt_ns);
    emulator_->on_time(hub_.now_ns());
  }
  // Only the clock and the emulator's timers (no frames handled).
  void advance(std::uint64_t dt_ns) noexcept {
    hub_.advance_ns(dt_ns);
    emulator_->on_time(hub_.now_ns());
  }

 private:
  drivers::InProcessHub hub_;
  drivers::InProcessBus* master_ = nullptr;
  drivers::InProcessBus* monitor_ = nullptr;
  std::unique_ptr<Plant> plant_;
  std::unique_ptr<DriveEmulator> emulator_;
};

}  // namespace dualv::sim
