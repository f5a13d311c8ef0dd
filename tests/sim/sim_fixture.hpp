#pragma once
// The Dual-V model and plant configuration from the shipped file, for sim tests.
#include <string>

#include "control/config/model_config.hpp"
#include "sim/plant.hpp"

namespace dualv::sim::test {

inline std::string config_file() { return std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml"; }
inline const model::Model& dual_v() {
  static const model::Model m = model::load_model_file(config_file());
  return m;
}

}  // namespace dualv::sim::test
