// Identification in closed loop against the simulated Dual-V: the plant's bodies differ from the
// configured model by up to +-20 % per body class (sim/plant.hpp mismatch knob), and the base
// parameters identified from the excitation program must be the plant's true ones (issue 16).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <regex>
#include <string>
#include <vector>

#include "apps/experiment/closed_loop.hpp"
#include "apps/experiment/robot_config.hpp"
#include "apps/identify/identify_config.hpp"
#include "apps/identify/recording_io.hpp"
#include "control/identification/excitation.hpp"
#include "control/identification/identify.hpp"
#include "control/identification/parameters.hpp"
#include "control/trajectory/program.hpp"

namespace dualv::apps {
namespace {

using namespace identification;

// The plant differs from the configured model by up to +-20 % per body class, with friction,
// every shipped realism knob of config/dualv.yaml on (one cycle of transport delay, 0.2 ms
// current loop, saturation), and the noise sources (encoder and torque quantisation) on when
// `noise`.
RobotConfig mismatched_config(bool noise) {
  RobotConfig cfg = load_robot_config(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  cfg.plant.mismatch.enabled = true;
  cfg.plant.mismatch.crank = {20.0, 10.0};
  cfg.plant.mismatch.coupler = {-20.0, 15.0};
  cfg.plant.mismatch.plate = {15.0, -20.0};
  cfg.plant.friction.enabled = true;
  EXPECT_TRUE(cfg.plant.transport_delay.enabled && cfg.plant.current_loop.enabled &&
              cfg.plant.saturation.enabled && cfg.plant.encoder.enabled &&
              cfg.plant.torque_quantisation.enabled)
      << "config/dualv.yaml no longer ships every realism knob on";
  cfg.plant.encoder.enabled = noise;
  cfg.plant.torque_quantisation.enabled = noise;
  return cfg;
}

IdentifyConfig shipped_identify_config() {
  return load_identify_config(std::string(DUALV_SOURCE_DIR) + "/config/identify.yaml");
}

struct Outcome {
  Identification id;
  Eigen::VectorXd truth;         // the plant's true base parameters
  Eigen::VectorXd contribution;  // |W_j| / |y|: torque share per unit of parameter j
};

// The excitation of config/identify.yaml run with its gain set (identify.run) on the simulated
// machine `cfg`, identified with the options `o`.
Outcome identify_in_simulation(const RobotConfig& cfg, IdentifyOptions o) {
  const IdentifyConfig icfg = shipped_identify_config();
  const BaseParameters base = find_base_parameters(cfg.model);
  const Excitation ex = design_excitation(cfg.model, base, cfg.trajectory.limits, icfg.excitation);
  Variant v;
  v.name = "excitation";
  const RunResult run = run_in_process(icfg.for_excitation_run(cfg), ex.program, v);
  EXPECT_TRUE(run.ok) << run.failure;
  o.torque_delay = drive_latency(cfg);
  const Recording rec = recording_from_run(run, cfg.period());
  const JointFriction nominal_friction{cfg.plant.friction.viscous, cfg.plant.friction.coulomb};
  Outcome out;
  out.id = identify(cfg.model, standard_parameters(cfg.model, nominal_friction), rec, o);
  // The truth: the plant's own bodies (make_true_model) and friction, through the same
  // base-parameter map.
  const sim::Plant plant(cfg.model, cfg.plant);
  out.truth = out.id.base.from_standard(standard_parameters(plant.true_model(), nominal_friction));
  const Observations obs = observations(cfg.model, out.id.base, process(rec, o), o);
  out.contribution = obs.W.colwise().norm().transpose() / obs.y.norm();
  for (int j = 0; j < out.id.base.size(); ++j)
    std::printf("%-14s true %12.6g identified %12.6g sigma %10.3g  z %6.2f  share %8.4f\n",
                out.id.base.name(j).c_str(), out.truth[j], out.id.estimate.phi[j],
                out.id.estimate.sigma[j],
                (out.id.estimate.phi[j] - out.truth[j]) / out.id.estimate.sigma[j],
                std::abs(out.truth[j]) * out.contribution[j]);
  return out;
}

// The base parameters whose estimate is more than 3 sigma from `truth`.
std::vector<std::string> outside_3_sigma(const Identification& id, const Eigen::VectorXd& truth) {
  std::vector<std::string> out;
  for (int j = 0; j < id.base.size(); ++j)
    if (std::abs(id.estimate.phi[j] - truth[j]) > 3.0 * id.estimate.sigma[j])
      out.push_back(id.base.name(j));
  return out;
}

TEST(IdentifyClosedLoop, WithoutNoiseTheBaseParametersAreThePlantsWithin2Percent) {
  // Transport delay, current loop and saturation on; no encoder or torque quantisation. Clean
  // data: the low-pass can sit far above the excitation (2 Hz) and keep the loop's own fast
  // motion, which a lower cutoff distorts through the regressor's nonlinearity (the defaults,
  // 50 Hz and every 4th sample, are for noisy encoders and torques).
  IdentifyOptions options = shipped_identify_config().estimation;
  options.cutoff_hz = 100.0;
  options.decimation = 2;
  const Outcome o = identify_in_simulation(mismatched_config(false), options);
  const Eigen::VectorXd& phi = o.id.estimate.phi;
  int significant = 0;
  for (int j = 0; j < o.id.base.size(); ++j) {
    const double err = phi[j] - o.truth[j];
    // A parameter that carries at least 5 % of the measured torques |y| must be within 2 % of
    // the plant's value. The others (the couplers' rotary inertia, zero first moments, viscous
    // friction: each under 1 % of the torques here) are held to the same torque error a 5 %
    // parameter may make: 2 % of 5 % of |y|.
    const double share = std::abs(o.truth[j]) * o.contribution[j];
    if (share >= 0.05) {
      ++significant;
      EXPECT_LT(std::abs(err), 0.02 * std::abs(o.truth[j])) << o.id.base.meaning(j);
    } else {
      EXPECT_LT(std::abs(err) * o.contribution[j], 0.02 * 0.05) << o.id.base.meaning(j);
    }
  }
  EXPECT_GE(significant, 6);  // the four crank inertias and the plate's mass and inertia at least
  // The identified values differ from the configuration's: the mismatch was found, not assumed.
  EXPECT_GT((o.id.nominal - o.truth).cwiseAbs().maxCoeff(), 0.05);
}

TEST(IdentifyClosedLoop, WithEveryRealismKnobOnTheBaseParametersAreThePlantsWithin3Sigma) {
  // config/identify.yaml's estimation as shipped (50 Hz, every 4th sample, instruments,
  // Newey-West sigma) on the +-20 % plant with encoder and torque quantisation too.
  const IdentifyOptions options = shipped_identify_config().estimation;
  ASSERT_TRUE(options.instruments);
  const RobotConfig cfg = mismatched_config(true);
  const Outcome o = identify_in_simulation(cfg, options);
  EXPECT_TRUE(o.id.estimate.instrumental);
  EXPECT_EQ(outside_3_sigma(o.id, o.truth), std::vector<std::string>{});
  // The test can fail: a plant whose plate is 20 % (of the model's plate mass) heavier than the
  // one simulated is not taken for it (plate.MR, the largest share of the torques, has a sigma
  // of about 2 % with this noise).
  RobotConfig heavier = cfg;
  heavier.plant.mismatch.plate.mass += 20.0;
  const JointFriction friction{cfg.plant.friction.viscous, cfg.plant.friction.coulomb};
  const Eigen::VectorXd wrong = o.id.base.from_standard(
      standard_parameters(sim::Plant(cfg.model, heavier.plant).true_model(), friction));
  const std::vector<std::string> detected = outside_3_sigma(o.id, wrong);
  EXPECT_NE(std::find(detected.begin(), detected.end(), "plate.MR"), detected.end());
}

TEST(IdentifyClosedLoop, WithoutInstrumentsTheClosedLoopNoiseBiasesTheEstimates) {
  // Why the instruments: in closed loop the torques react to the encoder noise the regressor
  // carries, so plain (weighted) least squares is biased beyond its sigma on the same data.
  IdentifyOptions options = shipped_identify_config().estimation;
  options.instruments = false;
  const Outcome o = identify_in_simulation(mismatched_config(true), options);
  EXPECT_FALSE(o.id.estimate.instrumental);
  EXPECT_FALSE(outside_3_sigma(o.id, o.truth).empty());
}

RunResult paper_run(const RobotConfig& cfg) {
  trajectory::ProgramContext ctx;
  ctx.start = ctx.home = cfg.model.home;
  const trajectory::Program program =
      trajectory::load_program_file(std::string(DUALV_SOURCE_DIR) + "/config/paper.yaml", ctx);
  Variant v;
  v.name = "paper";
  return run_in_process(cfg, program, v);
}

TEST(IdentifyClosedLoop, RefusesARecordingTooShortNamingTheTimeNeeded) {
  const RobotConfig cfg = load_robot_config(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  Recording rec = recording_from_run(paper_run(cfg), cfg.period());
  rec.t.resize(400);  // 0.4 s
  rec.X.resize(400);
  rec.tau.resize(400);
  try {
    identify(cfg.model, standard_parameters(cfg.model, {}), rec, IdentifyOptions{});
    FAIL() << "a 0.4 s recording was accepted";
  } catch (const IdentificationError& e) {
    EXPECT_NE(std::string(e.what()).find("not enough motion"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("need at least"), std::string::npos) << e.what();
  }
}

TEST(IdentifyClosedLoop, RefusesThePaperProgramAsAnExcitation) {
  // The paper's shapes keep the plate's angle constant and barely move some joints: the
  // regressor is ill conditioned, and the refusal says so with the number.
  const RobotConfig cfg = load_robot_config(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  const Recording rec = recording_from_run(paper_run(cfg), cfg.period());
  IdentifyOptions o;
  o.torque_delay = drive_latency(cfg);
  try {
    identify(cfg.model, standard_parameters(cfg.model, {}), rec, o);
    FAIL() << "the paper program was accepted as an excitation";
  } catch (const IdentificationError& e) {
    const std::string what = e.what();
    EXPECT_TRUE(what.find("condition number") != std::string::npos ||
                what.find("not enough motion") != std::string::npos)
        << what;
  }
}

TEST(IdentifyClosedLoop, RefusesAMotionNotExcitingEnoughWithItsConditionNumberAndWhatToChange) {
  // Every sample of the paper program kept (no joint-speed selection): enough samples, but the
  // plate never rotates, so the plate's and couplers' rotary parameters are barely excited.
  const RobotConfig cfg = load_robot_config(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  const Recording rec = recording_from_run(paper_run(cfg), cfg.period());
  IdentifyOptions o;
  o.torque_delay = drive_latency(cfg);
  o.min_joint_speed = 0.0;
  try {
    identify(cfg.model, standard_parameters(cfg.model, {}), rec, o);
    FAIL() << "the paper program was accepted as an excitation";
  } catch (const IdentificationError& e) {
    const std::string what = e.what();
    std::smatch m;
    ASSERT_TRUE(std::regex_search(what, m, std::regex("condition number ([0-9.e+]+)"))) << what;
    EXPECT_GT(std::stod(m[1]), o.max_condition) << what;
    // The same number as the scaled condition of the recording's own regressor.
    const BaseParameters base = find_base_parameters(cfg.model);
    const Observations obs = observations(cfg.model, base, process(rec, o), o);
    EXPECT_NEAR(std::stod(m[1]), weighted_least_squares(obs).condition, 2e-3 * std::stod(m[1]));
    EXPECT_NE(what.find("identify.estimation.max_condition"), std::string::npos) << what;
    EXPECT_NE(what.find("least excited"), std::string::npos) << what;
    EXPECT_NE(what.find("Use a richer motion"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace dualv::apps
