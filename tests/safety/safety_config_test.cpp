// The `safety:` section: defaults, the shipped file, and range errors naming the key.
#include "safety/safety_config.hpp"

#include <gtest/gtest.h>

#include "common/config_error.hpp"
#include "common/yaml_reader.hpp"

namespace dualv::safety {
namespace {

std::string problems_of(const std::string& yaml) {
  try {
    load_safety_config(YAML::Load(yaml));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(SafetyConfig, AbsentSectionGivesValidDefaults) {
  const SafetyConfig c = load_safety_config(YAML::Node());
  EXPECT_EQ(validate(c), "");
  EXPECT_EQ(c.torque.max, SafetyConfig{}.torque.max);
}

TEST(SafetyConfig, ShippedFileLoads) {
  const YAML::Node root =
      YamlReader::load_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  ASSERT_TRUE(root["safety"]) << "config/dualv.yaml has no safety: section";
  const SafetyConfig c = load_safety_config(root["safety"]);
  EXPECT_GT(c.torque.max, 0.0);
  EXPECT_LE(c.ss1.max_torque, c.torque.max);
}

TEST(SafetyConfig, ValuesAreRangeCheckedAndNamed) {
  EXPECT_NE(problems_of("torque: {max: 500}").find("safety.torque.max"), std::string::npos);
  EXPECT_NE(problems_of("torque: {max: -1}").find("safety.torque.max"), std::string::npos);
  EXPECT_NE(problems_of("max_joint_velocity: 0").find("safety.max_joint_velocity"),
            std::string::npos);
  EXPECT_NE(problems_of("workspace: {x: [0.1, -0.1]}").find("safety.workspace.x"),
            std::string::npos);
  EXPECT_NE(problems_of("ss1: {max_torque: 100, max_time: 0.5}").find("safety.ss1.max_torque"),
            std::string::npos);
  EXPECT_NE(problems_of("watchdogs: {stale_feedback_cycles: 0}").find("stale_feedback_cycles"),
            std::string::npos);
  EXPECT_NE(problems_of("torqeu: {max: 10}").find("safety.torqeu: unknown key"), std::string::npos);
  EXPECT_NE(problems_of("max_tracking_error: abc").find("safety.max_tracking_error"),
            std::string::npos);
  // Several problems at once, all reported.
  const std::string both = problems_of("max_plate_velocity: -1\nmin_serial_singularity: 2");
  EXPECT_NE(both.find("max_plate_velocity"), std::string::npos);
  EXPECT_NE(both.find("min_serial_singularity"), std::string::npos);
  EXPECT_EQ(problems_of("torque: {max: 50, max_rate: 20000}\nss1: {max_torque: 30}"), "");
}

}  // namespace
}  // namespace dualv::safety
