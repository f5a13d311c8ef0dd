#include "control/config/model_config.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <fstream>
#include <string>

#include "common/config_error.hpp"

namespace dualv::model {
namespace {

YAML::Node shipped_model() {
  return YAML::LoadFile(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml")["model"];
}

// Loads a modified copy of the shipped model and returns the error text ("" if it loaded).
template <typename Edit>
std::string error_after(Edit edit) {
  YAML::Node node = YAML::Clone(shipped_model());
  edit(node);
  try {
    load_model(node);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(ModelConfig, ShippedConfigurationLoadsWithTableIValues) {
  const Model m = load_model(shipped_model());
  EXPECT_EQ(m.n, 4);
  EXPECT_DOUBLE_EQ(m.chains[2].crank.mass, 1.169);
  EXPECT_DOUBLE_EQ(m.chains[3].coupler.inertia, 0.006417);
  EXPECT_DOUBLE_EQ(m.plate.mass, 0.899);
  EXPECT_DOUBLE_EQ(m.chains[1].base.y(), 0.5);
  EXPECT_EQ(m.chains[0].working_mode, -1);
}

TEST(ModelConfig, NegativeLengthIsNamed) {
  const auto e = error_after([](YAML::Node& n) { n["crank"]["length"] = -0.28; });
  EXPECT_NE(e.find("model.crank.length: must be in [0.001, 5] (got -0.28)"), std::string::npos)
      << e;
}

TEST(ModelConfig, NegativeMassIsNamed) {
  const auto e = error_after([](YAML::Node& n) { n["plate"]["mass"] = -1; });
  EXPECT_NE(e.find("model.plate.mass: must be in [0, 1000] (got -1)"), std::string::npos) << e;
}

TEST(ModelConfig, PerChainOverrideIsChecked) {
  const auto e = error_after([](YAML::Node& n) { n["chains"][2]["coupler"]["length"] = 0.0; });
  EXPECT_NE(e.find("model.chains[2].coupler.length: must be in [0.001, 5] (got 0)"),
            std::string::npos)
      << e;
}

TEST(ModelConfig, TooFewChains) {
  const auto e = error_after([](YAML::Node& n) {
    YAML::Node two;
    two.push_back(n["chains"][0]);
    two.push_back(n["chains"][1]);
    n["chains"] = two;
  });
  EXPECT_NE(e.find("model.chains: a planar n-RRR machine needs 3 to 8 chains (got 2)"),
            std::string::npos)
      << e;
}

TEST(ModelConfig, ThreeChainsAreAValidMachine) {
  const auto e = error_after([](YAML::Node& n) {
    YAML::Node three;
    for (int i = 0; i < 3; ++i) three.push_back(n["chains"][i]);
    n["chains"] = three;
  });
  EXPECT_EQ(e, "");
}

TEST(ModelConfig, UnreachableHomeIsNamed) {
  const auto e = error_after([](YAML::Node& n) { n["home"][1] = 1.5; });
  EXPECT_NE(e.find("model.home: the home pose [0, 1.5, 0] is not usable: unreachable"),
            std::string::npos)
      << e;
}

TEST(ModelConfig, SingularHomeIsNamed) {
  // Anchors collapsed to one point: the plate's rotation is not controlled.
  const auto e = error_after([](YAML::Node& n) {
    for (int i = 0; i < 4; ++i) {
      n["chains"][i]["anchor"][0] = 0.0;
      n["chains"][i]["anchor"][1] = 0.0;
    }
  });
  EXPECT_NE(e.find("parallel singularity"), std::string::npos) << e;
}

TEST(ModelConfig, UnknownKeyIsNamed) {
  const auto e = error_after([](YAML::Node& n) { n["chains"][1]["wroking_mode"] = 1; });
  EXPECT_NE(e.find("model.chains[1].wroking_mode: unknown key"), std::string::npos) << e;
}

TEST(ModelConfig, MissingKeyIsNamed) {
  const auto e = error_after([](YAML::Node& n) { n["plate"].remove("inertia"); });
  EXPECT_NE(e.find("model.plate.inertia: missing"), std::string::npos) << e;
}

TEST(ModelConfig, WrongTypeIsNamed) {
  const auto e = error_after([](YAML::Node& n) { n["coupler"]["mass"] = "heavy"; });
  EXPECT_NE(e.find("model.coupler.mass: must be a number (got 'heavy')"), std::string::npos) << e;
}

TEST(ModelConfig, WorkingModeMustBePlusOrMinusOne) {
  const auto e = error_after([](YAML::Node& n) { n["chains"][3]["working_mode"] = 0; });
  EXPECT_NE(e.find("model.chains[3].working_mode: must be +1 or -1 (got 0)"), std::string::npos)
      << e;
}

TEST(ModelConfig, WrongVectorLengthIsNamed) {
  const auto e = error_after([](YAML::Node& n) { n["chains"][0]["base"].push_back(1.0); });
  EXPECT_NE(e.find("model.chains[0].base: must be a list of 2 numbers"), std::string::npos) << e;
}

TEST(ModelConfig, EveryProblemIsReportedAtOnce) {
  const auto e = error_after([](YAML::Node& n) {
    n["crank"]["length"] = -1;
    n["plate"]["mass"] = "x";
    n["colour"] = "red";
  });
  EXPECT_NE(e.find("model.crank.length"), std::string::npos) << e;
  EXPECT_NE(e.find("model.plate.mass"), std::string::npos) << e;
  EXPECT_NE(e.find("model.colour: unknown key"), std::string::npos) << e;
}

TEST(ModelConfig, MissingFileAndSyntaxErrorsNameTheFile) {
  try {
    load_model_file("/nonexistent/dualv.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dualv.yaml: cannot open file"),
              std::string::npos);
  }
  const std::string path = ::testing::TempDir() + "bad.yaml";
  std::ofstream(path) << "model:\n  home: [0, 0.25\n";
  try {
    load_model_file(path);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("YAML syntax error"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "controller: {}\n";
  try {
    load_model_file(path);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("model: missing"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dualv::model
