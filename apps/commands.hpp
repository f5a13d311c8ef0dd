#pragma once
// Each `dualv` subcommand lives in its own file (apps/cmd_<name>.cpp) and registers
// itself here. A command's callback returns the process exit code through
// CommandResult; set-up errors are thrown as dualv::ConfigError and reported by main.
#include <CLI/CLI.hpp>

namespace dualv::apps {

// The --lcm help of the commands that send to `dualv run` (estop, start, reset, stream).
inline constexpr const char* kRobotUrlHelp =
    "LCM URL of the robot (its `dualv run --lcm`); commands go to its group one port up "
    "(runtime/lcm_url.hpp), where `dualv run` listens";

// Exit code chosen by the subcommand that ran (0 = success).
int& exit_code() noexcept;

void register_model_command(CLI::App& app);
void register_run_command(CLI::App& app);
void register_plot_command(CLI::App& app);
void register_bus_load_command(CLI::App& app);
void register_status_command(CLI::App& app);
void register_estop_command(CLI::App& app);
void register_reset_command(CLI::App& app);
void register_start_command(CLI::App& app);
void register_stream_command(CLI::App& app);
void register_check_target_command(CLI::App& app);
void register_sim_command(CLI::App& app);
void register_selftest_command(CLI::App& app);
void register_config_command(CLI::App& app);
void register_identify_command(CLI::App& app);
void register_eds_check_command(CLI::App& app);

}  // namespace dualv::apps
