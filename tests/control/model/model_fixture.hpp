#pragma once
// The Dual-V model from the shipped configuration, for model tests.
#include <random>

#include "control/config/model_config.hpp"

namespace dualv::model::test {

inline Model dual_v() {
  return load_model_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
}

// Uniform random poses in a box around home: +-8 cm in x and y, +-0.3 rad.
inline Pose random_pose(const Model& m, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> xy(-0.08, 0.08), th(-0.3, 0.3);
  return m.home + Pose(xy(rng), xy(rng), th(rng));
}

}  // namespace dualv::model::test
