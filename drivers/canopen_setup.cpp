#include "drivers/canopen_setup.hpp"

#include <fmt/format.h>

#include "drivers/canopen/boot.hpp"

namespace dualv::drivers {

canopen::MasterConfig master_config(const CanConfig& c) noexcept {
  canopen::MasterConfig m;
  m.node_id = c.master_node_id;
  m.heartbeat_period_ns = c.master_heartbeat_period_ns;
  m.sdo_timeout_ns = c.sdo_timeout_ns;
  m.node_heartbeat_timeout_ns = c.drive_heartbeat_timeout_ns;
  return m;
}

std::unique_ptr<CanopenActuatorSet> boot_actuator_set(
    CanBus& bus, const canopen::Clock& clock, canopen::Waiter& waiter, const CanConfig& config,
    const std::function<void(const std::string&)>& log) {
  validate(config);
  const fw::LayoutLoad load = require_bus_load_fits(config);
  if (log) log(format_bus_load(config, load));
  {
    canopen::CanopenMaster master(bus, clock, waiter, master_config(config));
    if (log)
      log(fmt::format("booting {} drives (NMT reset, SDO configuration, NMT start)",
                      config.size()));
    const std::vector<canopen::SkippedObject> skipped = canopen::boot_drives(master, config, log);
    if (log && skipped.empty()) log("every configured object written and read back");
  }
  auto set = std::make_unique<CanopenActuatorSet>(bus, clock, config);
  const std::uint32_t missing = set->prime(waiter, config.boot_timeout_ns);
  if (missing != 0) {
    std::string nodes;
    for (int i = 0; i < config.size(); ++i)
      if (missing & (1u << i))
        nodes += (nodes.empty() ? "" : ", ") +
                 std::to_string(config.drives[static_cast<std::size_t>(i)].node_id);
    throw canopen::CanopenError(fmt::format(
        "node(s) {} booted but sent no TPDO1 (180h + id) after SYNC within {} s: check the drive's "
        "TPDO1 transmission type and mapping",
        nodes, static_cast<double>(config.boot_timeout_ns) / 1e9));
  }
  if (log) log("drives booted: Operational, voltage disabled, positions read");
  return set;
}

bool CanopenDrives::shut_down(const std::function<void(const std::string&)>& log, int cycles) {
  canopen::SocketCanWaiter waiter(*bus_, *clock_);
  return actuators_->shut_down(waiter, log, cycles);
}

std::unique_ptr<CanopenDrives> open_canopen_drives(const CanConfig& config,
                                                   const CanopenSetupOptions& options) {
  CanConfig c = config;
  if (!options.interface.empty()) c.interface = options.interface;
  validate(c);
  if (options.control_period_s > 0.0) check_sync_period(c, options.control_period_s);
  (void)require_bus_load_fits(c);
  SocketCanConfig sc;
  sc.interface = c.interface;
  sc.fd_frames = c.bus_layout == fw::BusLayout::kFd;  // refused on an interface without FD
  auto bus = std::make_unique<SocketCanBus>(sc);
  auto clock = std::make_unique<canopen::SteadyClock>();
  canopen::SocketCanWaiter waiter(*bus, *clock);
  auto set = boot_actuator_set(*bus, options.clock != nullptr ? *options.clock : *clock, waiter, c,
                               options.log);
  return std::make_unique<CanopenDrives>(std::move(bus), std::move(clock), std::move(set));
}

}  // namespace dualv::drivers
