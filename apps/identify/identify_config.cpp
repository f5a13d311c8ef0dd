#include "apps/identify/identify_config.hpp"

#include <filesystem>

#include "common/config_error.hpp"
#include "common/yaml_reader.hpp"
#include "control/trajectory/shape.hpp"

namespace dualv::apps {

IdentifyConfig load_identify_config(const std::string& path, bool optional) {
  IdentifyConfig c;
  if (optional && !std::filesystem::exists(path)) return c;
  const YAML::Node root = YamlReader::load_file(path);
  ConfigProblems problems;
  YamlReader r(root["identify"], path + ": identify", problems.sink());
  {
    auto& e = c.excitation;
    YamlReader x = r.child("excitation", false);
    e.period = x.positive("period", e.period);
    e.harmonics = x.integer("harmonics", e.harmonics);
    x.require(e.harmonics >= 1 && e.harmonics <= static_cast<int>(trajectory::kMaxTerms),
              "harmonics", "must be in [1, 8]", e.harmonics);
    e.periods = x.integer("periods", e.periods);
    x.require(e.periods >= 1, "periods", "must be >= 1", e.periods);
    e.blend = x.positive("blend", e.blend);
    const auto amp = x.numbers(
        "amplitude", std::vector<double>{e.amplitude.x(), e.amplitude.y(), e.amplitude.z()});
    if (amp.size() == 3 && amp[0] > 0 && amp[1] > 0 && amp[2] >= 0)
      e.amplitude = model::Pose(amp[0], amp[1], amp[2]);
    else
      x.problem(x.key_path("amplitude") + ": must be [x m > 0, y m > 0, theta rad >= 0]");
    e.limit_fraction = x.in_range("limit_fraction", 0.05, 1.0, e.limit_fraction);
    e.ptp_duration = x.positive("ptp_duration", e.ptp_duration);
    e.candidates = x.integer("candidates", e.candidates);
    x.require(e.candidates >= 1, "candidates", "must be >= 1", e.candidates);
    e.refinements = x.integer("refinements", e.refinements);
    x.require(e.refinements >= 0, "refinements", "must be >= 0", e.refinements);
    e.seed = static_cast<std::uint64_t>(x.integer("seed", static_cast<int>(e.seed)));
    x.reject_unknown_keys();
  }
  {
    auto& o = c.estimation;
    YamlReader s = r.child("estimation", false);
    o.filter_order = s.integer("filter_order", o.filter_order);
    s.require(o.filter_order >= 2 && o.filter_order <= 8 && o.filter_order % 2 == 0, "filter_order",
              "must be 2, 4, 6 or 8", o.filter_order);
    o.cutoff_hz = s.positive("cutoff_hz", o.cutoff_hz);
    o.decimation = s.integer("decimation", o.decimation);
    s.require(o.decimation >= 1, "decimation", "must be >= 1", o.decimation);
    if (s.has("torque_delay")) c.torque_delay = s.non_negative("torque_delay");
    o.min_joint_speed = s.non_negative("min_joint_speed", o.min_joint_speed);
    o.trim = s.non_negative("trim", o.trim);
    o.min_duration = s.positive("min_duration", o.min_duration);
    o.max_condition = s.positive("max_condition", o.max_condition);
    o.instruments = s.boolean("instruments", o.instruments);
    o.correlation_periods = s.non_negative("correlation_periods", o.correlation_periods);
    s.reject_unknown_keys();
  }
  {
    YamlReader g = r.child("run", false);
    if (g.has("kp")) c.run_kp = g.positive("kp");
    if (g.has("kd")) c.run_kd = g.positive("kd");
    g.reject_unknown_keys();
  }
  r.reject_unknown_keys();
  problems.finish();
  return c;
}

}  // namespace dualv::apps
