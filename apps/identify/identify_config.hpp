#pragma once
// config/identify.yaml: the excitation and the estimation settings of `dualv identify`
// (issue 16). Every key is optional (defaults: control/identification/excitation.hpp and
// identify.hpp); an unknown key or a bad value throws dualv::ConfigError naming the key.
#include <optional>
#include <string>

#include "control/identification/excitation.hpp"
#include "control/identification/identify.hpp"

namespace dualv::apps {

struct IdentifyConfig {
  identification::ExcitationConfig excitation;
  identification::IdentifyOptions estimation;
  std::optional<double> torque_delay;  // [s]; absent: from the plant section (drive_latency)
};

// Reads the `identify:` map of a file; a missing file gives the defaults only when `optional`.
IdentifyConfig load_identify_config(const std::string& path, bool optional = false);

}  // namespace dualv::apps
