// load_plant_config: the shipped values, defaults, and one test per rule (each names its key).
#include <gtest/gtest.h>

#include <string>

#include "common/config_error.hpp"
#include "sim/plant.hpp"
#include "tests/sim/sim_fixture.hpp"

namespace dualv::sim {
namespace {

PlantConfig load(const std::string& yaml) { return load_plant_config(YAML::Load(yaml)["plant"]); }

// Loading must throw a ConfigError whose message names `key` with `rule`.
void expect_error(const std::string& yaml, const std::string& key, const std::string& rule) {
  try {
    load(yaml);
    ADD_FAILURE() << "no ConfigError for: " << yaml;
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(key), std::string::npos) << what;
    EXPECT_NE(what.find(rule), std::string::npos) << what;
  }
}

TEST(PlantConfig, ShippedFileTurnsEveryKnobOn) {
  const PlantConfig c = load_plant_config_file(test::config_file());
  EXPECT_DOUBLE_EQ(c.max_step, 1e-4);
  EXPECT_TRUE(c.friction.enabled);
  EXPECT_DOUBLE_EQ(c.friction.coulomb, 0.2);
  EXPECT_DOUBLE_EQ(c.friction.viscous, 0.02);
  EXPECT_DOUBLE_EQ(c.friction.smoothing_velocity, 0.01);
  EXPECT_TRUE(c.mismatch.enabled);
  EXPECT_DOUBLE_EQ(c.mismatch.crank.mass, 5.0);
  EXPECT_DOUBLE_EQ(c.mismatch.plate.inertia, 10.0);
  EXPECT_TRUE(c.encoder.enabled);
  EXPECT_EQ(c.encoder.counts_per_revolution, 1 << 20);
  EXPECT_TRUE(c.torque_quantisation.enabled);
  EXPECT_DOUBLE_EQ(c.torque_quantisation.rated_torque, 50.0);
  EXPECT_TRUE(c.current_loop.enabled);
  EXPECT_DOUBLE_EQ(c.current_loop.time_constant, 2e-4);
  EXPECT_TRUE(c.saturation.enabled);
  EXPECT_DOUBLE_EQ(c.saturation.peak_torque, 127.0);
  EXPECT_TRUE(c.transport_delay.enabled);
  EXPECT_EQ(c.transport_delay.cycles, 1);
}

TEST(PlantConfig, MissingSectionAndKeysTakeTheDefaults) {
  const PlantConfig none = load("other: 1");
  EXPECT_TRUE(none.friction.enabled && none.current_loop.enabled && none.transport_delay.enabled);
  const PlantConfig some = load("plant: {friction: {enabled: false}, integration_rate: 20000}");
  EXPECT_FALSE(some.friction.enabled);
  EXPECT_DOUBLE_EQ(some.friction.coulomb, PlantConfig{}.friction.coulomb);
  EXPECT_DOUBLE_EQ(some.max_step, 5e-5);
  EXPECT_TRUE(some.encoder.enabled);
}

TEST(PlantConfig, EachKnobSwitchesOff) {
  const PlantConfig c = load(
      "plant: {friction: {enabled: false}, mismatch: {enabled: false}, encoder: {enabled: false},"
      " torque_quantisation: {enabled: false}, current_loop: {enabled: false},"
      " saturation: {enabled: false}, transport_delay: {enabled: false}}");
  EXPECT_FALSE(c.friction.enabled || c.mismatch.enabled || c.encoder.enabled ||
               c.torque_quantisation.enabled || c.current_loop.enabled || c.saturation.enabled ||
               c.transport_delay.enabled);
}

TEST(PlantConfig, UnknownKeyIsAnError) {
  expect_error("plant: {friction: {coulomb: 0.1, stiction: 0.3}}", "plant.friction.stiction",
               "unknown key");
}
TEST(PlantConfig, UnknownTopLevelKeyIsAnError) {
  expect_error("plant: {integration_rat: 10000}", "plant.integration_rat", "unknown key");
}
TEST(PlantConfig, NegativeTimeConstantIsAnError) {
  expect_error("plant: {current_loop: {time_constant: -0.0002}}",
               "plant.current_loop.time_constant", "must be in [1e-07, 0.1]");
}
TEST(PlantConfig, ZeroCountsIsAnError) {
  expect_error("plant: {encoder: {counts_per_revolution: 0}}",
               "plant.encoder.counts_per_revolution", "must be >= 4");
}
TEST(PlantConfig, NonIntegerCountsIsAnError) {
  expect_error("plant: {encoder: {counts_per_revolution: 1.5}}",
               "plant.encoder.counts_per_revolution", "must be an integer");
}
TEST(PlantConfig, CoarseIntegrationRateIsAnError) {
  expect_error("plant: {integration_rate: 500}", "plant.integration_rate", "must be in");
}
// Issue 14: physically absurd values (unit mistakes) are refused with their range.
TEST(PlantConfig, AbsurdValuesAreRefusedWithTheirRange) {
  expect_error("plant: {saturation: {peak_torque: 127000}}", "plant.saturation.peak_torque",
               "must be in [0.001, 1000]");
  expect_error("plant: {current_loop: {time_constant: 2}}", "plant.current_loop.time_constant",
               "must be in [1e-07, 0.1]");
}

TEST(PlantConfig, NegativeFrictionIsAnError) {
  expect_error("plant: {friction: {coulomb: -0.1}}", "plant.friction.coulomb",
               "must be in [0, 100]");
  expect_error("plant: {friction: {viscous: -0.1}}", "plant.friction.viscous",
               "must be in [0, 100]");
}
TEST(PlantConfig, ZeroSmoothingVelocityIsAnError) {
  expect_error("plant: {friction: {smoothing_velocity: 0}}", "plant.friction.smoothing_velocity",
               "must be in [1e-06, 10]");
}
TEST(PlantConfig, MismatchOfMinus100PercentIsAnError) {
  expect_error("plant: {mismatch: {plate: {mass_percent: -100}}}",
               "plant.mismatch.plate.mass_percent", "must be in (-100, 1000]");
}
TEST(PlantConfig, UnknownBodyClassKeyIsAnError) {
  expect_error("plant: {mismatch: {crank: {length_percent: 3}}}",
               "plant.mismatch.crank.length_percent", "unknown key");
}
TEST(PlantConfig, NonPositiveRatedTorqueIsAnError) {
  expect_error("plant: {torque_quantisation: {rated_torque: 0}}",
               "plant.torque_quantisation.rated_torque", "must be in [0.001, 1000]");
}
TEST(PlantConfig, NonPositivePeakTorqueIsAnError) {
  expect_error("plant: {saturation: {peak_torque: -127}}", "plant.saturation.peak_torque",
               "must be in [0.001, 1000]");
}
TEST(PlantConfig, DelayCyclesOutOfRangeIsAnError) {
  expect_error("plant: {transport_delay: {cycles: 0}}", "plant.transport_delay.cycles",
               "must be in [1, 8]");
  expect_error("plant: {transport_delay: {cycles: 9}}", "plant.transport_delay.cycles",
               "must be in [1, 8]");
}
TEST(PlantConfig, NonBooleanEnabledIsAnError) {
  expect_error("plant: {saturation: {enabled: maybe}}", "plant.saturation.enabled",
               "must be true or false");
}
TEST(PlantConfig, EveryProblemIsReportedAtOnce) {
  try {
    load("plant: {encoder: {counts_per_revolution: 0}, current_loop: {time_constant: -1}}");
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.problems().size(), 2u) << e.what();
  }
}

}  // namespace
}  // namespace dualv::sim
