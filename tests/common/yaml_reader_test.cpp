#include "common/yaml_reader.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

namespace dualv {
namespace {

// Reads a small "loop" section the way set-up code does and returns the problems.
std::vector<std::string> read_loop(const std::string& yaml) {
  ConfigProblems problems;
  YAML::Node root = YAML::Load(yaml);
  YamlReader top(root, "", problems.sink());
  YamlReader loop = top.child("loop");
  loop.positive("rate_hz");
  loop.integer("priority", 80);
  loop.in_range("deadline_fraction", 0.1, 1.0, 1.0);
  loop.boolean("lock_memory", true);
  loop.reject_unknown_keys();
  top.reject_unknown_keys();
  return *problems.sink();
}

TEST(YamlReader, ValidSectionHasNoProblems) {
  EXPECT_TRUE(read_loop("loop: {rate_hz: 1000, priority: 90}").empty());
}

TEST(YamlReader, UnknownKeyIsNamedWithItsPath) {
  auto p = read_loop("loop: {rate_hz: 1000, rate_hzz: 5}\nextra: 1");
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0], "loop.rate_hzz: unknown key");
  EXPECT_EQ(p[1], "extra: unknown key");
}

TEST(YamlReader, MissingRequiredKeyIsNamed) {
  auto p = read_loop("loop: {priority: 90}");
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0], "loop.rate_hz: missing");
}

TEST(YamlReader, MissingSectionIsNamed) {
  auto p = read_loop("other: 1");
  ASSERT_GE(p.size(), 1u);
  EXPECT_EQ(p[0], "loop: missing");
}

bool has_problem(const std::vector<std::string>& p, const std::string& text) {
  return std::find(p.begin(), p.end(), text) != p.end();
}

// Only the type errors are asserted: a reader may add a follow-on range
// problem for the fallback value it then checks.
TEST(YamlReader, WrongTypeSaysWhatWasExpectedAndWhatWasGot) {
  auto p = read_loop("loop: {rate_hz: fast, priority: [1, 2], lock_memory: maybe}");
  EXPECT_TRUE(has_problem(p, "loop.rate_hz: must be a number (got 'fast')"));
  EXPECT_TRUE(has_problem(p, "loop.priority: must be an integer (got 'a non-scalar')"));
  EXPECT_TRUE(has_problem(p, "loop.lock_memory: must be true or false (got 'maybe')"));
}

TEST(YamlReader, RangeViolationsGiveTheRuleAndTheValue) {
  auto p = read_loop("loop: {rate_hz: -5, deadline_fraction: 1.5}");
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0], "loop.rate_hz: must be > 0 (got -5)");
  EXPECT_EQ(p[1], "loop.deadline_fraction: must be in [0.1, 1] (got 1.5)");
}

TEST(YamlReader, NonFiniteNumberIsRefused) {
  auto p = read_loop("loop: {rate_hz: .nan}");
  ASSERT_GE(p.size(), 1u);
  EXPECT_EQ(p[0], "loop.rate_hz: must be a finite number (got .nan)");
}

TEST(YamlReader, SequencesOfMapsCarryTheirIndexInThePath) {
  ConfigProblems problems;
  YamlReader top(YAML::Load("drives: [{id: 1}, {id: x}, {id: 3, bogus: 0}]"), "", problems.sink());
  for (auto& d : top.children("drives")) {
    d.integer("id");
    d.reject_unknown_keys();
  }
  top.reject_unknown_keys();
  const auto& p = *problems.sink();
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0], "drives[1].id: must be an integer (got 'x')");
  EXPECT_EQ(p[1], "drives[2].bogus: unknown key");
}

TEST(YamlReader, FinishThrowsConfigErrorListingEveryProblem) {
  ConfigProblems problems;
  YamlReader top(YAML::Load("a: -1"), "", problems.sink());
  top.positive("a");
  top.number("b");
  try {
    problems.finish();
    FAIL() << "finish() must throw";
  } catch (const ConfigError& e) {
    ASSERT_EQ(e.problems().size(), 2u);
    const std::string what = e.what();
    EXPECT_NE(what.find("a: must be > 0 (got -1)"), std::string::npos) << what;
    EXPECT_NE(what.find("b: missing"), std::string::npos) << what;
  }
}

TEST(YamlReader, MissingFileAndSyntaxErrorBecomeConfigErrors) {
  EXPECT_THROW(YamlReader::load_file("/nonexistent/dualv.yaml"), ConfigError);
  try {
    YamlReader::load_file("/nonexistent/dualv.yaml");
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open file"), std::string::npos);
  }
}

}  // namespace
}  // namespace dualv
