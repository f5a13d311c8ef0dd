#pragma once
// Loading a Model from YAML (set-up code: throws dualv::ConfigError listing every problem
// with its key; never returns a partial model). Lives above control/model, which reads no
// YAML (issue 13). Physical ranges: lengths in (0, 5] m, masses in [0, 1000] kg, inertias in
// [0, 100] kg m^2, |gravity| <= 20 m/s^2.
#include <yaml-cpp/yaml.h>

#include <string>

#include "control/model/model.hpp"

namespace dualv::model {

// Reads the `model:` map of a dualv configuration (see config/dualv.yaml).
Model load_model(const YAML::Node& model_node);
// Reads `model:` from a whole configuration file.
Model load_model_file(const std::string& path);

}  // namespace dualv::model
