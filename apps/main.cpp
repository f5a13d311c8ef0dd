// dualv: driver and control stack for redundantly actuated parallel robots.
#include <fmt/core.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>

#include "apps/commands.hpp"
#include "common/config_error.hpp"

namespace dualv::apps {
int& exit_code() noexcept {
  static int code = 0;
  return code;
}
}  // namespace dualv::apps

int main(int argc, char** argv) {
  // A log file, a pipe or the journal gets each line when it is written (stdout is otherwise
  // block-buffered there): progress, e-stops and stops are seen while they happen, and a
  // script watching the log acts on the run as it is, not on what a 4 KiB buffer held back.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  CLI::App app{"dualv: real-time control of the Dual-V redundantly actuated parallel robot"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "dualv 0.1.0");
  dualv::apps::register_model_command(app);
  dualv::apps::register_run_command(app);
  dualv::apps::register_plot_command(app);
  dualv::apps::register_bus_load_command(app);
  dualv::apps::register_status_command(app);
  dualv::apps::register_estop_command(app);
  dualv::apps::register_reset_command(app);
  dualv::apps::register_start_command(app);
  dualv::apps::register_stream_command(app);
  dualv::apps::register_check_target_command(app);
  dualv::apps::register_sim_command(app);
  dualv::apps::register_selftest_command(app);
  dualv::apps::register_config_command(app);
  dualv::apps::register_identify_command(app);
  dualv::apps::register_eds_check_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const dualv::ConfigError& e) {
    fmt::print(stderr, "dualv: {}\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "dualv: error: {}\n", e.what());
    return 1;
  }
  return dualv::apps::exit_code();
}
