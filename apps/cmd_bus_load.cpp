// `dualv bus-load`: the worst-case CAN bus load of the configured drives at the control rate.
#include <fmt/core.h>

#include "apps/commands.hpp"
#include "apps/config_path.hpp"
#include "common/yaml_reader.hpp"
#include "drivers/canopen_config.hpp"

namespace dualv::apps {

void register_bus_load_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "bus-load", "Worst-case CAN bits per cycle and bus load of the `can:` configuration");
  static std::string config;
  add_config_option(*cmd, config);
  cmd->callback([] {
    const std::string path = resolve_config(config);
    const drivers::CanConfig can = drivers::load_can_config(YamlReader::load_file(path)["can"]);
    const fw::BusLoadReport report = drivers::bus_load_report(can);
    fmt::print("{}\n", drivers::format_bus_load(can, report));
    exit_code() = report.fits ? 0 : 1;
  });
}

}  // namespace dualv::apps
