// `dualv eds-check` and `dualv sim --eds` (apps/cmd_eds_check.cpp, apps/cmd_sim.cpp), the real
// binary: the shipped EDS passes with the shipped configuration; an EDS without 60C2h boots
// with 60C2h optional (skipped, named) and not with it required; a malformed EDS is named
// with file:line by both commands.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/dualv_process.hpp"

namespace {

namespace fs = std::filesystem;

using Exit = dualv::test::CliResult;
Exit run(const std::string& args) { return dualv::test::run_cli(DUALV_BINARY, args); }

std::string source(const std::string& rel) { return std::string(DUALV_SOURCE_DIR) + "/" + rel; }
const std::string kEds = source("config/eds/dualv-emulated-drive.eds");
const std::string kConfig = source("config/dualv.yaml");

std::string slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

fs::path temp(const std::string& name, const std::string& text) {
  const fs::path p =
      fs::temp_directory_path() / ("dualv_eds_cli_" + std::to_string(::getpid()) + "_" + name);
  std::ofstream(p) << text;
  return p;
}

// The shipped EDS without object `index` ("60C2"): its sections dropped, its entry taken out
// of [OptionalObjects] and the list renumbered.
std::string eds_without(const std::string& index) {
  std::istringstream in(slurp(kEds));
  std::vector<std::string> out;
  bool drop = false;
  bool in_optional = false;
  int number = 0;
  std::size_t count_line = 0;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line[0] == '[') {
      drop = line.rfind("[" + index, 0) == 0;
      in_optional = line == "[OptionalObjects]";
    }
    if (drop) continue;
    if (in_optional && line.rfind("SupportedObjects=", 0) == 0) count_line = out.size();
    if (in_optional && !line.empty() && std::isdigit(static_cast<unsigned char>(line[0]))) {
      if (line.find("=0x" + index) != std::string::npos) continue;
      line = std::to_string(++number) + line.substr(line.find('='));
    }
    out.push_back(line);
  }
  out[count_line] = "SupportedObjects=" + std::to_string(number);
  std::string s;
  for (const std::string& l : out) s += l + "\n";
  return s;
}

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(EdsCheckCli, ShippedEdsPassesWithTheShippedConfiguration) {
  const Exit e = run("eds-check " + kEds + " -c " + kConfig);
  EXPECT_EQ(e.exit_code, 0) << e.output;
  for (int node = 1; node <= 4; ++node)
    EXPECT_NE(e.output.find("node " + std::to_string(node) + " (can.drives[" +
                            std::to_string(node - 1) + "]): can boot"),
              std::string::npos)
        << e.output;
  EXPECT_EQ(count(e.output, "skipped:"), 0) << e.output;
  EXPECT_EQ(count(e.output, "problem:"), 0) << e.output;
}

TEST(EdsCheckCli, OptionalObjectMissingIsSkippedRequiredIsRefused) {
  const fs::path eds = temp("no60c2.eds", eds_without("60C2"));
  const Exit optional = run("eds-check " + eds.string() + " -c " + kConfig + " --node 3");
  EXPECT_EQ(optional.exit_code, 0) << optional.output;
  EXPECT_EQ(count(optional.output, "node 3 (can.drives[2]): can boot"), 1) << optional.output;
  EXPECT_EQ(count(optional.output, "node 1"), 0) << optional.output;  // --node 3 only
  EXPECT_EQ(count(optional.output,
                  "skipped: node 3: interpolation_period skipped (optional): "
                  "60C2h sub1"),
            1)
      << optional.output;

  std::string cfg = slurp(kConfig);
  const std::string key = "interpolation_period: optional";
  ASSERT_NE(cfg.find(key), std::string::npos);
  cfg.replace(cfg.find(key), key.size(), "interpolation_period: required");
  const fs::path required_cfg = temp("required.yaml", cfg);
  const Exit required = run("eds-check " + eds.string() + " -c " + required_cfg.string());
  EXPECT_EQ(required.exit_code, 1) << required.output;
  EXPECT_EQ(count(required.output, "CANNOT boot"), 4) << required.output;
  EXPECT_EQ(count(required.output, "can.objects.interpolation_period is required"), 4)
      << required.output;
  fs::remove(eds);
  fs::remove(required_cfg);
}

TEST(EdsCheckCli, MalformedEdsNamedWithFileAndLine) {
  std::string text = slurp(kEds);
  const std::string key = "[6071]\nParameterName=Target torque\nObjectType=0x7\nDataType=0x0003";
  const std::size_t at = text.find(key);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, key.size(),
               "[6071]\nParameterName=Target torque\nObjectType=0x7\nDataType=0xZ3");
  const int line =
      1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n')) +
      3;
  const fs::path eds = temp("bad.eds", text);
  const std::string where = eds.string() + ":" + std::to_string(line) + ": bad number for DataType";
  const Exit check = run("eds-check " + eds.string() + " -c " + kConfig);
  EXPECT_EQ(check.exit_code, 1) << check.output;
  EXPECT_NE(check.output.find(where), std::string::npos) << check.output;
  // `dualv sim --eds` reads the EDS before it opens the bus.
  const Exit sim = run("sim --eds " + eds.string() + " -c " + kConfig + " --can dualv-none0");
  EXPECT_EQ(sim.exit_code, 1) << sim.output;
  EXPECT_NE(sim.output.find(where), std::string::npos) << sim.output;
  fs::remove(eds);
}

TEST(EdsCheckCli, UnknownNodeRefused) {
  const Exit e = run("eds-check " + kEds + " -c " + kConfig + " --node 9");
  EXPECT_EQ(e.exit_code, 1) << e.output;
  EXPECT_NE(e.output.find("--node 9: no drive with that node_id"), std::string::npos) << e.output;
}

}  // namespace
