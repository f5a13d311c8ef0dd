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
  // Joint gains of the excitation run (identify.run); absent: the configuration's controller.
  // The shipped file halves kp: see config/identify.yaml and docs/identification.md.
  std::optional<double> run_kp, run_kd;  // [N m / rad], [N m s / rad], every joint
  // The configuration with the excitation run's gains applied.
  template <class Config>
  Config for_excitation_run(Config cfg) const {
    if (run_kp) cfg.control.controller.kp.setConstant(*run_kp);
    if (run_kd) cfg.control.controller.kd.setConstant(*run_kd);
    return cfg;
  }
};

// Reads the `identify:` map of a file; a missing file gives the defaults only when `optional`.
IdentifyConfig load_identify_config(const std::string& path, bool optional = false);

}  // namespace dualv::apps
