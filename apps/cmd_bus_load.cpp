// `dualv bus-load`: the worst-case CAN bus load of the configured drives at the control rate,
// for the layout the master boots (checked against can.max_bus_load, as at boot) and for every
// layout of issue 15 side by side (firmware_if/bus_layout.hpp).
#include <fmt/core.h>

#include <string>

#include "apps/commands.hpp"
#include "apps/config_path.hpp"
#include "common/yaml_reader.hpp"
#include "drivers/canopen_config.hpp"
#include "firmware_if/bus_layout.hpp"

namespace dualv::apps {

namespace {

std::string frames_text(const fw::LayoutTraffic& t) {
  std::string s;
  for (std::uint8_t i = 0; i < t.count; ++i) {
    const fw::TrafficItem& it = t.items[i];
    if (!s.empty()) s += ", ";
    s += fmt::format("{} x {} ({} B, {}{} bits", it.frames, it.what, it.bytes, it.bits.nominal,
                     it.bits.data ? fmt::format(" + {} data-phase", it.bits.data) : "");
    s += it.min_interval_s > 0 ? fmt::format(", at most every {:g} ms)", 1e3 * it.min_interval_s)
                               : ")";
  }
  return s;
}

std::string layouts_table(const fw::BusParams& p, double hz) {
  std::string s = fmt::format(
      "Layouts for {} drives at {:.1f} Hz, {} bit/s nominal, {} bit/s CAN FD data phase; event "
      "PDOs counted at their inhibit time (statusword {:g} ms, controlword {:g} ms); limits "
      "{:.0f} % cyclic, {:.0f} % with event frames (worst-case stuffing):\n",
      p.drives, hz, p.nominal_bitrate, p.data_bitrate, 1e3 * p.statusword_inhibit_s,
      1e3 * p.controlword_inhibit_s, 100.0 * p.max_cyclic_load, 100.0 * p.max_total_load);
  s += fmt::format("{:<10} {:>10} {:>10} {:>9} {:>8} {:>8} {:>10} {:>10}  {}\n", "layout",
                   "bits/cycle", "data-phase", "us/cycle", "cyclic", "+events", "100% rate",
                   "max rate", "fits");
  for (fw::BusLayout layout : fw::kBusLayouts) {
    const fw::LayoutLoad r = fw::layout_load(layout, p, hz);
    s += fmt::format(
        "{:<10} {:>10} {:>10} {:>9.1f} {:>6.1f} % {:>6.1f} % {:>7.1f} Hz {:>7.1f} Hz  {}\n",
        fw::to_string(layout), r.cyclic_bits.nominal, r.cyclic_bits.data, 1e6 * r.cycle_time_s,
        100.0 * r.cyclic_load, 100.0 * r.total_load, r.full_rate_hz, r.max_rate_hz,
        r.fits ? "yes" : "NO");
  }
  s += "(bits/cycle at the nominal rate, data-phase bits at the data rate; max rate: the highest "
       "control rate within both limits)\n";
  for (fw::BusLayout layout : fw::kBusLayouts)
    s += fmt::format("  {}: {}\n", fw::to_string(layout),
                     frames_text(fw::layout_traffic(layout, p)));
  return s;
}

}  // namespace

void register_bus_load_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "bus-load",
      "Worst-case CAN bits per cycle and bus load of the `can:` configuration, and of every "
      "layout (per-drive RPDO, broadcast RPDO, CAN FD) side by side");
  static std::string config;
  static fw::BusParams params;  // only the options given override the configuration
  add_config_option(*cmd, config);
  static CLI::Option* statusword_inhibit = nullptr;
  static CLI::Option* controlword_inhibit = nullptr;
  static CLI::Option* data_bitrate = nullptr;
  data_bitrate = cmd->add_option("--data-bitrate", params.data_bitrate,
                                 "CAN FD data-phase bit rate [bit/s] (default: "
                                 "can.fd.data_bitrate)");
  data_bitrate->check(CLI::Range(1'000'000u, 12'000'000u));
  statusword_inhibit = cmd->add_option("--statusword-inhibit", params.statusword_inhibit_s,
                                       "broadcast layout: the statusword event TPDO's inhibit "
                                       "time [s] (default: can.statusword_inhibit)");
  statusword_inhibit->check(CLI::Range(1e-4, 6.5535));
  controlword_inhibit = cmd->add_option("--controlword-inhibit", params.controlword_inhibit_s,
                                        "broadcast layout: the controlword event RPDO's inhibit "
                                        "time [s] (default: can.controlword_inhibit)");
  controlword_inhibit->check(CLI::Range(1e-4, 6.5535));
  cmd->callback([] {
    const std::string path = resolve_config(config);
    const drivers::CanConfig can = drivers::load_can_config(YamlReader::load_file(path)["can"]);
    const fw::LayoutLoad report = drivers::bus_load_report(can);
    fmt::print("{}\n\n", drivers::format_bus_load(can, report));
    fw::BusParams p = drivers::bus_params(can);
    if (*data_bitrate) p.data_bitrate = params.data_bitrate;
    if (*statusword_inhibit) p.statusword_inhibit_s = params.statusword_inhibit_s;
    if (*controlword_inhibit) p.controlword_inhibit_s = params.controlword_inhibit_s;
    fmt::print("{}", layouts_table(p, can.cycle_hz()));
    exit_code() = report.fits ? 0 : 1;
  });
}

}  // namespace dualv::apps
