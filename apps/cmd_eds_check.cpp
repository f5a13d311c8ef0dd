// `dualv eds-check FILE [-c CONFIG] [--node N]`: does the drive a vendor's EDS (CiA 306)
// describes have what the `can:` configuration needs, before anything touches the bus?
// drivers/canopen/eds_check.hpp checks it against the master's own boot list; this prints,
// per drive (every drive of the configuration, or node N): the problems (boot would fail),
// the optional objects boot would skip and what skipping them means. Exit 0 when every
// checked drive can boot, 1 otherwise; a malformed EDS is named with file:line (exit 1), a
// bad configuration key by main (exit 2).
#include <fmt/core.h>

#include <memory>
#include <string>

#include "apps/commands.hpp"
#include "apps/config_path.hpp"
#include "drivers/canopen/eds_check.hpp"
#include "drivers/canopen_config.hpp"
#include "firmware_if/eds.hpp"

namespace dualv::apps {

namespace {

struct EdsCheckArgs {
  std::string eds;
  std::string config;
  int node = 0;  // 0: every drive of the configuration
};

int run_eds_check(const EdsCheckArgs& a) {
  const std::string path = resolve_config(a.config);
  const drivers::CanConfig can = drivers::load_can_config_file(path);
  fw::eds::Eds eds;
  try {
    eds = fw::eds::read_eds_file(a.eds);
  } catch (const fw::eds::EdsError& e) {
    fmt::print(stderr, "dualv eds-check: {}\n", e.what());
    return 1;
  }
  if (a.node != 0 && can.drive_of_node(static_cast<std::uint8_t>(a.node)) < 0) {
    fmt::print(stderr,
               "dualv eds-check: --node {}: no drive with that node_id in {} (can.drives)\n",
               a.node, path);
    return 1;
  }
  fmt::print("EDS {} ({} objects) against the can: section of {}\n", a.eds, eds.objects.size(),
             path);
  bool ok = true;
  for (int i = 0; i < can.size(); ++i) {
    const std::uint8_t node = can.drives[static_cast<std::size_t>(i)].node_id;
    if (a.node != 0 && node != a.node) continue;
    const drivers::canopen::EdsCheckReport r = drivers::canopen::check_eds(eds, can, i);
    fmt::print("node {} (can.drives[{}]): {}\n", node, i,
               r.can_boot() ? "can boot"
                            : fmt::format("CANNOT boot, {} problem{}", r.problems.size(),
                                          r.problems.size() == 1 ? "" : "s"));
    for (const std::string& p : r.problems) fmt::print("  problem: {}\n", p);
    for (const std::string& s : r.skipped) fmt::print("  skipped: {}\n", s);
    for (const std::string& n : r.notes) fmt::print("  safety:  {}\n", n);
    ok = ok && r.can_boot();
  }
  fmt::print("{}\n", ok ? "ok: the drive has every object the configuration needs"
                        : "NOT ok: fix the EDS / drive or the can: section (can.objects)");
  return ok ? 0 : 1;
}

}  // namespace

void register_eds_check_command(CLI::App& app) {
  auto args = std::make_shared<EdsCheckArgs>();
  CLI::App* cmd = app.add_subcommand(
      "eds-check",
      "Check a drive's EDS (CiA 306) against the `can:` configuration before booting it: every "
      "object present with the right type, access and PDO mapping; what would be skipped");
  cmd->add_option("FILE", args->eds, "The drive's EDS file")->required();
  add_config_option(*cmd, args->config);
  cmd->add_option("--node", args->node,
                  "Check only the drive with this node_id (default: every configured drive)")
      ->check(CLI::Range(1, 127));
  cmd->callback([args] { exit_code() = run_eds_check(*args); });
}

}  // namespace dualv::apps
