// `dualv config check FILE`: checks a robot configuration (or a program, checked against
// --config) without running anything and prints every problem at once, each naming the file,
// the key path and the reason (issue 14). Exit 0 when the file is valid, 1 when it is not.
#include <fmt/core.h>

#include <string>
#include <vector>

#include "apps/commands.hpp"
#include "apps/config_path.hpp"
#include "apps/experiment/robot_config.hpp"
#include "common/config_error.hpp"
#include "common/yaml_reader.hpp"
#include "control/trajectory/preflight.hpp"
#include "control/trajectory/program.hpp"

namespace dualv::apps {

namespace {

// A program file: loaded as `dualv run` loads it, then pre-flighted at the loop rate.
std::vector<std::string> check_program(const std::string& file, const std::string& config) {
  const RobotConfig cfg = load_robot_config(config);
  try {
    trajectory::ProgramContext ctx;
    ctx.start = ctx.home = cfg.model.home;
    ctx.workspace = cfg.trajectory.limits.workspace;
    const trajectory::Program program = trajectory::load_program_file(file, ctx);
    const trajectory::PreflightReport report =
        trajectory::preflight(cfg.model, program, cfg.trajectory.limits);
    std::vector<std::string> out;
    for (const auto& v : report.violations) out.push_back(fmt::format("{}: {}", file, v.message));
    return out;
  } catch (const ConfigError& e) {
    return e.problems();
  }
}

}  // namespace

void register_config_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("config", "Check configuration and program files");
  cmd->require_subcommand(1);
  auto* check = cmd->add_subcommand(
      "check",
      "Check FILE without running anything: a robot configuration (every section, key, range "
      "and cross-check), or a program (a file with `program:`) against --config, pre-flight "
      "included. Prints every problem (file, key path, reason); exit 0 valid, 1 not");
  static std::string file;
  static std::string config;
  check->add_option("FILE", file, "The YAML file to check")->required();
  add_config_option(*check, config);
  check->callback([] {
    std::vector<std::string> problems;
    bool is_program = false;
    try {
      is_program = YamlReader::load_file(file)["program"].IsDefined();
      problems =
          is_program ? check_program(file, resolve_config(config)) : check_robot_config(file);
    } catch (const ConfigError& e) {
      problems = e.problems();
    }
    for (const auto& p : problems) fmt::print("{}\n", p);
    if (problems.empty())
      fmt::print("{}: ok ({})\n", file,
                 is_program ? "program, pre-flight passed" : "configuration");
    else
      fmt::print("{}: {} problem{}\n", file, problems.size(), problems.size() == 1 ? "" : "s");
    exit_code() = problems.empty() ? 0 : 1;
  });
}

}  // namespace dualv::apps
