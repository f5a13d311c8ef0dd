// config/identify.yaml: the shipped file says what the code's defaults are, and bad keys are
// named. PlantConfig::true_model: the plant the identified model is compared on.
#include "apps/identify/identify_config.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "apps/experiment/robot_config.hpp"
#include "common/config_error.hpp"
#include "control/config/model_config.hpp"
#include "sim/plant.hpp"

namespace dualv::apps {
namespace {

TEST(IdentifyConfig, ShippedFileStatesTheDefaults) {
  const IdentifyConfig c =
      load_identify_config(std::string(DUALV_SOURCE_DIR) + "/config/identify.yaml");
  const identification::ExcitationConfig e;
  const identification::IdentifyOptions o;
  EXPECT_EQ(c.excitation.period, e.period);
  EXPECT_EQ(c.excitation.harmonics, e.harmonics);
  EXPECT_EQ(c.excitation.periods, e.periods);
  EXPECT_EQ(c.excitation.blend, e.blend);
  EXPECT_EQ(c.excitation.amplitude, e.amplitude);
  EXPECT_EQ(c.excitation.limit_fraction, e.limit_fraction);
  EXPECT_EQ(c.excitation.candidates, e.candidates);
  EXPECT_EQ(c.excitation.refinements, e.refinements);
  EXPECT_EQ(c.excitation.seed, e.seed);
  EXPECT_EQ(c.estimation.filter_order, o.filter_order);
  EXPECT_EQ(c.estimation.cutoff_hz, o.cutoff_hz);
  EXPECT_EQ(c.estimation.decimation, o.decimation);
  EXPECT_EQ(c.estimation.min_joint_speed, o.min_joint_speed);
  EXPECT_EQ(c.estimation.max_condition, o.max_condition);
  EXPECT_EQ(c.estimation.instruments, o.instruments);
  EXPECT_EQ(c.estimation.correlation_periods, o.correlation_periods);
  EXPECT_FALSE(c.torque_delay.has_value());
}

TEST(IdentifyConfig, TheExcitationRunsWithTheStatedGainsTheOtherRunsWithTheConfigurations) {
  const IdentifyConfig c =
      load_identify_config(std::string(DUALV_SOURCE_DIR) + "/config/identify.yaml");
  ASSERT_TRUE(c.run_kp && c.run_kd);
  EXPECT_EQ(*c.run_kp, 3500.0);  // docs/identification.md states this gain set
  EXPECT_EQ(*c.run_kd, 20.0);
  const RobotConfig cfg = load_robot_config(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  const RobotConfig run = c.for_excitation_run(cfg);
  EXPECT_TRUE((run.control.controller.kp.array() == 3500.0).all());
  EXPECT_TRUE((run.control.controller.kd.array() == 20.0).all());
  EXPECT_TRUE((cfg.control.controller.kp.array() == 7000.0).all());  // the copy only
}

TEST(IdentifyConfig, NamesEveryBadKey) {
  const std::string path = ::testing::TempDir() + "/identify_bad.yaml";
  std::ofstream(path) << "identify:\n  estimation:\n    cutof_hz: 3\n    decimation: 0\n"
                         "  excitation:\n    harmonics: 9\n  run:\n    kp: -1\n";
  try {
    load_identify_config(path);
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("identify.estimation.cutof_hz: unknown key"), std::string::npos) << what;
    EXPECT_NE(what.find("identify.estimation.decimation"), std::string::npos) << what;
    EXPECT_NE(what.find("identify.excitation.harmonics"), std::string::npos) << what;
    EXPECT_NE(what.find("identify.run.kp"), std::string::npos) << what;
  }
}

TEST(PlantTrueModel, WhenGivenIsThePlantsModelAndTheMismatchIsNotApplied) {
  const model::Model nominal =
      model::load_model_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  sim::PlantConfig cfg;  // mismatch on by default
  model::Model given = nominal;
  given.plate.mass = 1.234;
  given.chains[2].crank.inertia = 0.02;
  cfg.true_model = given;
  const sim::Plant plant(nominal, cfg);
  EXPECT_EQ(plant.true_model().plate.mass, 1.234);
  EXPECT_EQ(plant.true_model().chains[2].crank.inertia, 0.02);
  EXPECT_EQ(plant.true_model().chains[0].crank.mass, nominal.chains[0].crank.mass);
}

}  // namespace
}  // namespace dualv::apps
