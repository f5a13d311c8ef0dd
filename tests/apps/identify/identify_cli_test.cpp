// `dualv identify` (apps/cmd_identify.cpp), the real binary: bad recordings are refused with
// exit code 3, the reason and what to change (issue 16); the settings file it reads by default
// is the default config folder's (the installed package's /etc/dualv/identify.yaml,
// scripts/package-test.sh runs that case).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <regex>
#include <string>

#include "tests/support/dualv_process.hpp"

namespace {

using Exit = dualv::test::CliResult;
Exit run(const std::string& args) { return dualv::test::run_cli(DUALV_BINARY, args); }

// A CSV as `dualv run` writes it (the columns identify reads): the plate moving along x, with a
// little rotation in phase, x = A sin(2 pi t), theta = 0.2 A / m sin(2 pi t) about home
// (0, 0.25, 0), with some torques, `seconds` long at 1 kHz.
std::string write_csv(const std::string& name, double seconds, double amplitude) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream out(path);
  out << "t,segment,x_d,y_d,theta_d,x,y,theta,ex_mm,ey_mm,tau1,tau2,tau3,tau4\n";
  for (int k = 0; k < static_cast<int>(seconds * 1000.0); ++k) {
    const double t = k * 1e-3, x = amplitude * std::sin(2.0 * std::numbers::pi * 1.0 * t);
    const double tau = 0.5 * std::cos(2.0 * std::numbers::pi * 1.0 * t);
    const double th = 0.2 * x;
    out << t << ",0," << x << ",0.25," << th << "," << x << ",0.25," << th << ",0,0," << tau << ","
        << -tau << "," << tau << "," << -tau << "\n";
  }
  return path;
}

TEST(IdentifyCli, ARecordingTooShortIsRefusedWithExitCode3AndTheTimeNeeded) {
  const std::string csv = write_csv("identify_short.csv", 0.3, 0.01);
  const Exit r = run("identify --log " + csv + " --out " + ::testing::TempDir() + "/id_short");
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("dualv identify: refused"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("need at least"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("record a longer run"), std::string::npos) << r.output;
}

TEST(IdentifyCli, AMotionWithOneSinusoidIsRefusedWithItsConditionNumberAndWhatToChange) {
  // 6 s of motion, every sample kept (min_joint_speed 0): enough samples, but one sinusoid in x
  // and theta together, none in y: most base parameters are barely excited.
  const std::string csv = write_csv("identify_x_only.csv", 6.0, 0.01);
  const std::string settings = ::testing::TempDir() + "/identify_all_samples.yaml";
  std::ofstream(settings) << "identify:\n  estimation:\n    min_joint_speed: 0.0\n";
  const Exit r = run("identify --log " + csv + " --identify-config " + settings + " --out " +
                     ::testing::TempDir() + "/id_x_only");
  EXPECT_EQ(r.exit_code, 3) << r.output;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.output, m, std::regex("condition number ([0-9.e+]+)")))
      << r.output;
  EXPECT_GT(std::stod(m[1]), 500.0) << r.output;  // identify.estimation.max_condition
  EXPECT_NE(r.output.find("identify.estimation.max_condition"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("Use a richer motion"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(::testing::TempDir() + "/id_x_only/identified.yaml"));
}

TEST(IdentifyCli, ReadsItsSettingsFromTheDefaultConfigFolder) {
  const Exit r = run("identify --help");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find(std::string(DUALV_CONFIG_DIR) + "/identify.yaml"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find(std::string(DUALV_CONFIG_DIR) + "/paper.yaml"), std::string::npos)
      << r.output;
}

}  // namespace
