// A robot configuration file is complete and strict (issue 14, defect 1 and 2): every
// refusal names the file, the key path and the reason. Each case edits a copy of the shipped
// config/dualv.yaml as a user would (text, not parsed nodes), so yaml-cpp's own behaviour
// (duplicate keys, nulls) is part of what is tested.
#include "apps/experiment/robot_config.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "common/config_error.hpp"

namespace dualv::apps {
namespace {

const std::string kShipped = std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml";

std::string shipped_text() {
  std::ifstream in(kShipped, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string write_temp(const std::string& text, const std::string& name = "robot.yaml") {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("dualv_robot_config_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// The shipped text with `from` (which must occur exactly once) replaced by `to`.
std::string edited(const std::string& from, const std::string& to) {
  std::string t = shipped_text();
  const auto at = t.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  EXPECT_EQ(t.find(from, at + 1), std::string::npos) << from << " occurs twice";
  if (at != std::string::npos) t.replace(at, from.size(), to);
  return t;
}

std::vector<std::string> problems_of_text(const std::string& text) {
  return check_robot_config(write_temp(text));
}

// True when one problem contains every fragment.
::testing::AssertionResult has_problem(const std::vector<std::string>& problems,
                                       const std::vector<std::string>& fragments) {
  for (const auto& p : problems)
    if (std::all_of(fragments.begin(), fragments.end(),
                    [&](const std::string& f) { return p.find(f) != std::string::npos; }))
      return ::testing::AssertionSuccess();
  auto r = ::testing::AssertionFailure() << "no problem contains all of:";
  for (const auto& f : fragments) r << " [" << f << "]";
  r << "\nproblems:";
  for (const auto& p : problems) r << "\n  " << p;
  return r;
}

TEST(RobotConfig, ShippedFileIsCompleteAndValid) {
  const auto p = check_robot_config(kShipped);
  EXPECT_TRUE(p.empty()) << (p.empty() ? "" : p.front());
}

TEST(RobotConfig, DuplicateKeyIsRefusedWithBothLines) {
  const std::string text = edited("    max: 60.0 ", "    max: 60.0\n    max: 600.0 ");
  const auto p = problems_of_text(text);
  const std::string file = write_temp(text);
  EXPECT_TRUE(has_problem(p, {file, "safety.torque.max: duplicate key (first at line"}));
}

TEST(RobotConfig, SecondSectionIsADuplicate) {
  const auto p = problems_of_text(shipped_text() + "\nsafety:\n  max_joint_velocity: 100.0\n");
  EXPECT_TRUE(has_problem(p, {"safety: duplicate key"}));
}

TEST(RobotConfig, UnknownSectionsAreRefused) {
  const auto p = problems_of_text(shipped_text() + "\nlcm: {url: x}\ndrives: [junk]\n");
  EXPECT_TRUE(has_problem(p, {"lcm: unknown section"}));
  EXPECT_TRUE(has_problem(p, {"drives: unknown section"}));
}

TEST(RobotConfig, NullValueIsRefusedNotDefaulted) {
  const auto p =
      problems_of_text(edited("  max_joint_velocity: 12.0 ", "  max_joint_velocity: ~ "));
  EXPECT_TRUE(has_problem(p, {"safety.max_joint_velocity: no value"}));
  const auto q = problems_of_text(edited("  kd: 20.0 ", "  kd: "));
  EXPECT_TRUE(has_problem(q, {"controller.kd: no value"}));
}

TEST(RobotConfig, MissingSectionIsRefused) {
  std::string t = shipped_text();
  t = t.substr(0, t.find("\nsafety:"));
  EXPECT_TRUE(has_problem(problems_of_text(t), {"safety: missing section"}));
}

TEST(RobotConfig, MissingKeyIsRefusedNotDefaulted) {
  const auto p = problems_of_text(edited("    max_rate: 30000.0 ", "    # max_rate: gone "));
  EXPECT_TRUE(has_problem(p, {"safety.torque.max_rate: missing"}));
  const auto q = problems_of_text(edited("    viscous: 0.02 ", "    # viscous: gone "));
  EXPECT_TRUE(has_problem(q, {"plant.friction.viscous: missing"}));
}

// A file cut at any line that loses a key is refused: whatever it lost, nothing is filled
// in from code. (A cut inside the last comment loses nothing and still loads.)
TEST(RobotConfig, TruncatedFileIsRefusedAtEveryLine) {
  const std::string text = shipped_text();
  std::vector<std::size_t> line_ends;
  for (std::size_t i = 0; i < text.size(); ++i)
    if (text[i] == '\n') line_ends.push_back(i + 1);
  auto holds_a_key = [](const std::string& rest) {
    std::istringstream in(rest);
    for (std::string line; std::getline(in, line);) {
      const auto first = line.find_first_not_of(' ');
      if (first != std::string::npos && line[first] != '#') return true;
    }
    return false;
  };
  int cuts = 0;
  for (std::size_t end : line_ends) {
    if (!holds_a_key(text.substr(end))) break;
    const auto p = problems_of_text(text.substr(0, end));
    EXPECT_FALSE(p.empty()) << "cut after byte " << end << " was accepted";
    ++cuts;
  }
  EXPECT_GT(cuts, 100);
  // The cut points, mid-line: 50 %, 75 % and 99 % of the bytes.
  for (double f : {0.5, 0.75, 0.99}) {
    const std::string cut =
        text.substr(0, static_cast<std::size_t>(f * static_cast<double>(text.size())));
    if (holds_a_key(text.substr(cut.size()))) {
      EXPECT_FALSE(problems_of_text(cut).empty()) << f;
    }
  }
}

TEST(RobotConfig, AbsurdValuesAreRefusedWithTheirRange) {
  EXPECT_TRUE(
      has_problem(problems_of_text(edited("velocity_cutoff_hz: 250.0", "velocity_cutoff_hz: 1e12")),
                  {"controller.velocity_cutoff_hz: must be in"}));
  // Above Nyquist of the 1 kHz loop, though a plausible filter on its own.
  EXPECT_TRUE(has_problem(
      problems_of_text(edited("velocity_cutoff_hz: 250.0", "velocity_cutoff_hz: 600.0")),
      {"controller.velocity_cutoff_hz: must be below the loop's Nyquist rate", "500"}));
  EXPECT_TRUE(has_problem(problems_of_text(edited("    max: 60.0 ", "    max: 1000.0 ")),
                          {"safety.torque.max: must be in (0, 127] N m"}));
  EXPECT_TRUE(
      has_problem(problems_of_text(edited("max_joint_torque: 40.0 ", "max_joint_torque: 4000.0 ")),
                  {"trajectory.limits.max_joint_torque: must be in"}));
  EXPECT_TRUE(has_problem(problems_of_text(edited("kp: 7000.0 ", "kp: .inf ")),
                          {"controller.kp: must be a finite number"}));
  EXPECT_TRUE(has_problem(problems_of_text(edited("kp: 7000.0 ", "kp: 7e9 ")),
                          {"controller.kp: must be in (0, 1000000]"}));
}

TEST(RobotConfig, CanSectionIsValidatedForInProcessRuns) {
  const auto p = problems_of_text(edited("  bitrate: 1000000 ", "  bitrate: fast "));
  EXPECT_TRUE(has_problem(p, {"can.bitrate"}));
}

// `dualv config check` said "ok" for this file and `dualv run --can` refused it: the run
// read `can:` a second time with the safety limit, the check did not.
TEST(RobotConfig, DriveTorqueLimitAboveTheSafetyLimitIsRefusedByTheCheck) {
  std::string t = shipped_text();
  const std::string from = "max_torque: 60.0, peak_torque";
  const auto at = t.find(from);
  ASSERT_NE(at, std::string::npos);
  t.replace(at, from.size(), "max_torque: 100.0, peak_torque");
  EXPECT_TRUE(has_problem(problems_of_text(t),
                          {"robot.yaml: can.drives[0].max_torque: 100 N m is above the safety "
                           "limit safety.torque.max = 60 N m"}));
}

TEST(RobotConfig, EveryProblemAtOnceEachNamingTheFile) {
  std::string t = edited("velocity_cutoff_hz: 250.0", "velocity_cutoff_hz: 1e12");
  t.replace(t.find("    max: 60.0 "), 14, "    max: 1000.0 ");
  const std::string file = write_temp(t, "two_problems.yaml");
  const auto p = check_robot_config(file);
  EXPECT_TRUE(has_problem(p, {file + ": ", "controller.velocity_cutoff_hz"}));
  EXPECT_TRUE(has_problem(p, {file + ": ", "safety.torque.max"}));
  for (const auto& line : p) EXPECT_EQ(line.rfind(file, 0), 0u) << line;
}

TEST(RobotConfig, EmptyBinaryAndForeignFilesSaySo) {
  EXPECT_TRUE(
      has_problem(check_robot_config(write_temp("", "empty.yaml")), {"empty.yaml", "empty file"}));
  EXPECT_TRUE(has_problem(check_robot_config(write_temp("# only a comment\n", "c.yaml")),
                          {"c.yaml", "empty file"}));
  EXPECT_TRUE(has_problem(check_robot_config(write_temp(std::string("\x7f"
                                                                    "ELF\x02\x01\x01\0\0",
                                                                    9),
                                                        "bin.yaml")),
                          {"bin.yaml", "not a YAML file: binary content"}));
  EXPECT_TRUE(has_problem(check_robot_config(write_temp("just some words\n", "words.yaml")),
                          {"words.yaml", "not a YAML configuration", "a single value"}));
  EXPECT_TRUE(has_problem(check_robot_config(write_temp("model: [1, 2\n", "syntax.yaml")),
                          {"syntax.yaml:", "YAML syntax error"}));
  EXPECT_TRUE(has_problem(check_robot_config("/nonexistent/dualv.yaml"),
                          {"/nonexistent/dualv.yaml", "cannot open file"}));
}

// `dualv run --rate HZ` (override_rate): the checks that depend on the rate run again, naming
// the key and --rate; the thresholds below are hand-computed from config/dualv.yaml.
std::vector<std::string> override_problems(double rate_hz, bool on_bus) {
  RobotConfig cfg = load_robot_config(kShipped);
  const RobotConfig before = cfg;
  try {
    override_rate(cfg, rate_hz, on_bus);
  } catch (const ConfigError& e) {
    // Refused: nothing of the configuration changed.
    EXPECT_EQ(cfg.loop.period_ns, before.loop.period_ns);
    EXPECT_EQ(cfg.can.sync_period_ns, before.can.sync_period_ns);
    return e.problems();
  }
  return {};
}

TEST(RobotConfigRate, AcceptedRateMovesTheSyncAndThePreflightPeriodWithTheLoop) {
  RobotConfig cfg = load_robot_config(kShipped);
  override_rate(cfg, 800.0, true);
  EXPECT_EQ(cfg.loop.period_ns, 1'250'000);
  EXPECT_EQ(cfg.can.sync_period_ns, 1'250'000u);
  EXPECT_DOUBLE_EQ(cfg.trajectory.limits.loop_period, 0.00125);
  // The paper's 10 kHz stays possible in simulation (plant.integration_rate 10000 Hz), not
  // on the bus (below).
  RobotConfig sim = load_robot_config(kShipped);
  EXPECT_NO_THROW(override_rate(sim, 10000.0, false));
}

TEST(RobotConfigRate, VelocityFilterMustStayBelowTheNewNyquistRate) {
  // velocity_cutoff_hz: 250 -> the loop must run above 500 Hz.
  EXPECT_TRUE(has_problem(override_problems(500.0, false),
                          {"dualv.yaml: controller.velocity_cutoff_hz: must be below the loop's "
                           "Nyquist rate --rate 500 / 2 = 250 Hz (got 250)"}));
  EXPECT_TRUE(override_problems(501.0, false).empty());
}

TEST(RobotConfigRate, PlantMustIntegrateAtLeastAtTheNewRate) {
  // plant.integration_rate: 10000 Hz.
  EXPECT_TRUE(has_problem(override_problems(10001.0, false),
                          {"plant.integration_rate: must be >= --rate 10001"}));
}

TEST(RobotConfigRate, SafetyTimesCountedInCyclesMustLastACycle) {
  // safety.ss1.standstill_time 0.01 s: at most 100 Hz; the filter (250 Hz) refuses first
  // anyway, both are reported.
  const auto p = override_problems(99.0, false);
  EXPECT_TRUE(has_problem(p, {"safety.ss1.standstill_time: must last at least one control "
                              "cycle, 1 / --rate 99"}));
  EXPECT_TRUE(has_problem(p, {"controller.velocity_cutoff_hz"}));
  EXPECT_FALSE(has_problem(override_problems(100.0, false), {"safety.ss1.standstill_time"}));
  // command_stream_timeout 0.1 s: exactly one cycle at 10 Hz is enough, 9 Hz is not.
  EXPECT_FALSE(
      has_problem(override_problems(10.0, false), {"safety.watchdogs.command_stream_timeout"}));
  EXPECT_TRUE(has_problem(override_problems(9.0, false),
                          {"safety.watchdogs.command_stream_timeout: must last at least one"}));
}

TEST(RobotConfigRate, CanDeadlinesFollowTheSyncPeriod) {
  // can.rpdo_deadline 0.01 s must be longer than the SYNC period: refused at 100 Hz and below.
  EXPECT_TRUE(has_problem(override_problems(100.0, false),
                          {"dualv.yaml: can.rpdo_deadline: must be longer than can.sync.period",
                           "(with --rate 100 Hz)"}));
}

TEST(RobotConfigRate, BusLoadIsCheckedWhenTheRunDrivesTheBus) {
  // DESIGN.md "CAN contract": 895 bits per cycle worst case with the per-drive layout; the
  // cyclic frames may take 90 % of 1 Mbit/s (can.max_cyclic_load, issue 15):
  // 900000 / 895 = 1005.59 cycles/s.
  EXPECT_TRUE(override_problems(1005.0, true).empty());
  EXPECT_TRUE(has_problem(override_problems(1006.0, true),
                          {"dualv.yaml: can.sync.period: 1006.0 Hz with the per_drive layout needs",
                           "(with --rate 1006 Hz)"}));
  EXPECT_TRUE(override_problems(1062.0, false).empty()) << "in-process: no bus to load";
}

}  // namespace
}  // namespace dualv::apps
