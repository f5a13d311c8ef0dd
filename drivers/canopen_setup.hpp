#pragma once
// Set-up helpers for apps (not real-time): from the `can:` configuration to booted drives.
//
//   CanConfig cfg = load_can_config(root["can"]);            // canopen_config.hpp
//   auto drives = open_canopen_drives(cfg, {.interface = "can0", .control_period_s = 1e-3});
//   drives->actuators();                                       // an ActuatorSet, primed
//
// open_canopen_drives(): checks the configuration, the SYNC period against the control
// period and the worst-case bus load (refused with both numbers), opens SocketCanBus on the
// interface, boots every drive (drivers/canopen/boot.hpp: NMT reset, boot-up, SDO
// configuration with read-back, NMT start), and primes the actuator set so its first
// read() has real positions. Every failure throws with a message saying what to fix:
// dualv::ConfigError (a key), drivers::CanSetupError (the interface),
// canopen::BootTimeoutError (which node did not boot), canopen::SdoError (which node and
// object, the abort code and its text).
//
// Between the return and the first cycle of the loop, keep calling actuators().service()
// at least every master heartbeat period if the loop does not start at once: the drives
// watch the master's heartbeat (1016h) and stop (6007h) when it is silent.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "drivers/can/socketcan_bus.hpp"
#include "drivers/canopen/clock.hpp"
#include "drivers/canopen/master.hpp"
#include "drivers/canopen/waiter.hpp"
#include "drivers/canopen_actuator_set.hpp"
#include "drivers/canopen_config.hpp"

namespace dualv::drivers {

struct CanopenSetupOptions {
  std::string interface;          // overrides can.interface when not empty (--can IFACE)
  double control_period_s = 0.0;  // checked against can.sync.period when > 0
  std::function<void(const std::string&)> log;  // progress lines; may be empty
  // The clock the actuator set reads (must outlive the drives); null: the drives' own
  // CLOCK_MONOTONIC. A paced loop passes its canopen::CycleClock over that same clock
  // (drivers/canopen/cycle_clock.hpp): a cycle's reads and writes then take its wake-up time.
  const canopen::Clock* clock = nullptr;
};

// Booted drives on their own SocketCAN socket; owns the bus and the clock.
class CanopenDrives {
 public:
  CanopenDrives(std::unique_ptr<SocketCanBus> bus, std::unique_ptr<canopen::SteadyClock> clock,
                std::unique_ptr<CanopenActuatorSet> actuators) noexcept
      : bus_(std::move(bus)), clock_(std::move(clock)), actuators_(std::move(actuators)) {}
  CanopenActuatorSet& actuators() noexcept { return *actuators_; }
  SocketCanBus& bus() noexcept { return *bus_; }
  // After the loop: torque 0 + disable voltage for a few SYNC cycles, then NMT as
  // can.on_exit says, each step logged (CanopenActuatorSet::shut_down). Not real-time.
  bool shut_down(const std::function<void(const std::string&)>& log, int cycles = 5);
  const canopen::Clock& clock() const noexcept { return *clock_; }

 private:
  std::unique_ptr<SocketCanBus> bus_;
  std::unique_ptr<canopen::SteadyClock> clock_;
  std::unique_ptr<CanopenActuatorSet> actuators_;  // destroyed first (holds references)
};

std::unique_ptr<CanopenDrives> open_canopen_drives(const CanConfig& config,
                                                   const CanopenSetupOptions& options = {});

// The same sequence over any bus (the in-process simulation, tests): boot, then a primed
// actuator set. Throws as above.
std::unique_ptr<CanopenActuatorSet> boot_actuator_set(
    CanBus& bus, const canopen::Clock& clock, canopen::Waiter& waiter, const CanConfig& config,
    const std::function<void(const std::string&)>& log = {});

// The master configuration boot uses, from the `can:` section.
canopen::MasterConfig master_config(const CanConfig& config) noexcept;

}  // namespace dualv::drivers
