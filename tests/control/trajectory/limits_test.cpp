// control/trajectory/limits.hpp: the `trajectory:` section of the configuration.
#include "control/trajectory/limits.hpp"

#include <gtest/gtest.h>

#include "common/config_error.hpp"
#include "test_util.hpp"

namespace dualv::trajectory {
namespace {

const char* kGood = R"(
trajectory:
  limits:
    workspace: {x: [-0.1, 0.1], y: [0.15, 0.35], theta: [-0.3, 0.3]}
    min_parallel_singularity: 0.2
    min_serial_singularity: 0.2
    max_joint_speed: 10
    max_plate_acceleration: 20
    max_plate_angular_acceleration: 100
    max_joint_torque: 40
  rebase: {max_speed: 0.05, max_acceleration: 0.5, max_angular_speed: 0.5,
           max_angular_acceleration: 5}
)";

TrajectoryConfig load(const std::string& text) {
  return load_trajectory_config(YAML::Load(text)["trajectory"]);
}

void expect_error(std::string text, const std::string& from, const std::string& to,
                  const std::string& fragment) {
  text.replace(text.find(from), from.size(), to);
  try {
    load(text);
    ADD_FAILURE() << "no error for " << to;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(Limits, LoadsTheShippedConfiguration) {
  const TrajectoryConfig c = test::dualv_trajectory_config();
  EXPECT_LT(c.limits.workspace.x.lo, 0.0);
  EXPECT_GT(c.limits.max_joint_torque, 0.0);
  EXPECT_GT(c.rebase.max_speed, 0.0);
}

TEST(Limits, LoadsAllKeys) {
  const TrajectoryConfig c = load(kGood);
  EXPECT_EQ(c.limits.workspace.y.lo, 0.15);
  EXPECT_EQ(c.limits.workspace.theta.hi, 0.3);
  EXPECT_EQ(c.limits.max_plate_angular_acceleration, 100);
  EXPECT_EQ(c.limits.sample_period, 5e-4);  // default
  EXPECT_EQ(c.rebase.max_angular_acceleration, 5);
  EXPECT_EQ(c.rebase.tolerance, 1e-9);
}

TEST(Limits, RefusesUnknownKey) {
  expect_error(kGood, "max_joint_torque: 40", "max_joint_torque: 40\n    max_jerk: 1",
               "trajectory.limits.max_jerk: unknown key");
}

TEST(Limits, RefusesMissingKey) {
  expect_error(kGood, "max_joint_speed: 10", "", "trajectory.limits.max_joint_speed: missing");
}

TEST(Limits, RefusesNonPositiveLimit) {
  expect_error(kGood, "max_joint_torque: 40", "max_joint_torque: -40",
               "trajectory.limits.max_joint_torque: must be in [0.001, 127] (got -40)");
}

// Issue 14: a limit above the hardware (the drives' 127 N m peak) or a unit mistake.
TEST(Limits, RefusesLimitsAboveTheHardware) {
  expect_error(kGood, "max_joint_torque: 40", "max_joint_torque: 400",
               "trajectory.limits.max_joint_torque: must be in [0.001, 127] (got 400)");
  expect_error(kGood, "max_joint_speed: 10", "max_joint_speed: 1e6",
               "trajectory.limits.max_joint_speed: must be in");
}

TEST(Limits, StreamingSectionIsOptionalAndChecked) {
  const StreamingLimits d;
  EXPECT_EQ(load(kGood).streaming.max_speed, d.max_speed);  // absent: the defaults
  const std::string with = std::string(kGood) +
                           "  streaming: {max_speed: 0.2, max_acceleration: 3, "
                           "max_angular_speed: 1, max_angular_acceleration: 10}\n";
  const TrajectoryConfig c = load(with);
  EXPECT_EQ(c.streaming.max_speed, 0.2);
  EXPECT_EQ(c.streaming.max_acceleration, 3);
  EXPECT_EQ(c.streaming.max_angular_acceleration, 10);
  expect_error(with, "max_acceleration: 3", "max_acceleration: 30",
               "trajectory.streaming.max_acceleration: must not exceed");
  expect_error(with, "max_angular_acceleration: 10", "max_angular_acceleration: 200",
               "trajectory.streaming.max_angular_acceleration: must not exceed");
  expect_error(with, "max_speed: 0.2", "max_speed: 0", "trajectory.streaming.max_speed");
  expect_error(with, "max_speed: 0.2", "max_speed: 0.2, jerk: 1",
               "trajectory.streaming.jerk: unknown key");
}

TEST(Limits, RefusesEmptyInterval) {
  expect_error(kGood, "x: [-0.1, 0.1]", "x: [0.1, -0.1]",
               "trajectory.limits.workspace.x: must have min < max");
}

TEST(Limits, RefusesIntervalOfWrongLength) {
  expect_error(kGood, "x: [-0.1, 0.1]", "x: [0.1]",
               "trajectory.limits.workspace.x: must be [min, max] (got 1 numbers)");
}

TEST(Limits, RefusesSerialMeasureAboveOne) {
  expect_error(kGood, "min_serial_singularity: 0.2", "min_serial_singularity: 2",
               "trajectory.limits.min_serial_singularity: must be in [0, 1]");
}

TEST(Limits, RefusesMissingSection) {
  EXPECT_THROW(load_trajectory_config(YAML::Load("model: {}")["trajectory"]), ConfigError);
}

TEST(Limits, IntervalContains) {
  const Interval i{-1, 1};
  EXPECT_TRUE(i.contains(1));
  EXPECT_FALSE(i.contains(1.0000001));
  EXPECT_FALSE(i.contains(NAN));
}

}  // namespace
}  // namespace dualv::trajectory
