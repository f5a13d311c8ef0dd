// `dualv bus-load` (apps/cmd_bus_load.cpp), the real binary: the configured drives, bit rate
// and SYNC period reach the side-by-side table, whose figures are checked against values
// computed by hand from the frame sizes (docs/architecture.md "Beating the naive bus limit").
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/dualv_process.hpp"

namespace {

namespace fs = std::filesystem;

using Exit = dualv::test::CliResult;
Exit run(const std::string& args) { return dualv::test::run_cli(DUALV_BINARY, args); }

// The table's row of each layout, split at blanks:
// layout bits data us cyclic % events % full Hz max Hz fits
std::map<std::string, std::vector<std::string>> rows(const std::string& out) {
  std::map<std::string, std::vector<std::string>> r;
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);) {
    std::istringstream words(line);
    std::vector<std::string> w;
    for (std::string s; words >> s;) w.push_back(s);
    if (w.size() == 13 && (w[0] == "per_drive" || w[0] == "broadcast" || w[0] == "fd")) r[w[0]] = w;
  }
  return r;
}

TEST(BusLoadCli, ShippedConfigurationByHand) {
  const Exit e = run("bus-load -c " + std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  ASSERT_EQ(e.exit_code, 0) << e.output;
  const auto r = rows(e.output);
  ASSERT_EQ(r.size(), 3u) << e.output;
  // 55 + 4 x 95 + 4 x 115; 55 + 135 + 4 x 95; FD: 55 + 33 + 4 x 33 nominal, 194 + 4 x 94 data.
  EXPECT_EQ(r.at("per_drive")[1], "895");
  EXPECT_EQ(r.at("per_drive")[4], "89.5");
  EXPECT_EQ(r.at("broadcast")[1], "570");
  EXPECT_EQ(r.at("broadcast")[6], "63.0");  // 57 % + 8 event frames of 75 us per 10 ms
  EXPECT_EQ(r.at("fd")[1], "220");
  EXPECT_EQ(r.at("fd")[2], "570");
  EXPECT_EQ(r.at("fd")[3], "334.0");  // 220 us + 570 bits at 5 Mbit/s
  for (const auto& [layout, w] : r) EXPECT_EQ(w[12], "yes") << layout;
}

TEST(BusLoadCli, TwoDrivesAt2500HzByHand) {
  const fs::path cfg =
      fs::temp_directory_path() / ("dualv_bus_load_cli_" + std::to_string(::getpid()) + ".yaml");
  {
    std::ofstream f(cfg);
    f << "can:\n  sync: {period: 0.0004}\n  drives:\n    - {node_id: 1}\n    - {node_id: 2}\n";
  }
  const Exit e = run("bus-load -c " + cfg.string());
  fs::remove(cfg);
  // The master's layout (per-drive) needs 475 us every 400 us: refused, as at boot.
  EXPECT_EQ(e.exit_code, 1) << e.output;
  const auto r = rows(e.output);
  ASSERT_EQ(r.size(), 3u) << e.output;
  // per-drive 55 + 2 x 95 + 2 x 115 = 475 bits: 118.75 % at 2.5 kHz.
  EXPECT_EQ(r.at("per_drive")[1], "475");
  EXPECT_EQ(r.at("per_drive")[12], "NO");
  // broadcast: 55 + torques (4 B) 95 + 2 x 95 = 340 bits = 85 %; events 4 x 75 us / 10 ms
  // = 3 %: 88 %.
  EXPECT_EQ(r.at("broadcast")[1], "340");
  EXPECT_EQ(r.at("broadcast")[4], "85.0");
  EXPECT_EQ(r.at("broadcast")[6], "88.0");
  EXPECT_EQ(r.at("broadcast")[12], "yes");
  // FD: RPDO 8 B = 33 + (5 + 64 + 27 + floor(85 / 4) - 3 = 114); 2 x TPDO 6 B = 33 + 94.
  // 55 + 33 + 66 = 154 nominal, 114 + 188 = 302 data bits: 154 us + 60.4 us = 214.4 us.
  EXPECT_EQ(r.at("fd")[1], "154");
  EXPECT_EQ(r.at("fd")[2], "302");
  EXPECT_EQ(r.at("fd")[3], "214.4");
  EXPECT_EQ(r.at("fd")[12], "yes");
}

}  // namespace
