// The `plant:` section reader (sim/plant.hpp load_plant_config): apart from the physics in
// sim/plant.cpp so the fuzz build can leave libFuzzer's compare hooks out of the 10 kHz
// integration (fuzz/CMakeLists.txt) while this reader, which robot_config_fuzz feeds, keeps
// them.
#include <fmt/format.h>

#include <string>

#include "common/yaml_reader.hpp"
#include "sim/plant.hpp"

namespace dualv::sim {

namespace {

void read_mismatch(YamlReader& parent, const char* key, MismatchPercent& m) {
  YamlReader r = parent.child(key, false);
  m.mass = r.number("mass_percent", m.mass);
  m.inertia = r.number("inertia_percent", m.inertia);
  // A body may be lighter than configured, but it must keep a positive mass and inertia.
  r.require(m.mass > -100.0 && m.mass <= 1000.0, "mass_percent", "must be in (-100, 1000]", m.mass);
  r.require(m.inertia > -100.0 && m.inertia <= 1000.0, "inertia_percent", "must be in (-100, 1000]",
            m.inertia);
  r.reject_unknown_keys();
}

}  // namespace

PlantConfig load_plant_config(const YAML::Node& plant_node) {
  ConfigProblems problems;
  PlantConfig c;
  // An absent `plant:` section is allowed: every knob at its default (all on).
  YamlReader r(plant_node, "plant", problems.sink());
  const double rate = r.number("integration_rate", 1.0 / c.max_step);
  r.require(rate >= 1000.0 && rate <= 1e7, "integration_rate", "must be in [1000, 1e7] Hz", rate);
  if (rate > 0.0) c.max_step = 1.0 / rate;
  {
    YamlReader f = r.child("friction", false);
    c.friction.enabled = f.boolean("enabled", c.friction.enabled);
    c.friction.coulomb = f.in_range("coulomb", 0.0, 100.0, c.friction.coulomb);
    c.friction.viscous = f.in_range("viscous", 0.0, 100.0, c.friction.viscous);
    c.friction.smoothing_velocity =
        f.in_range("smoothing_velocity", 1e-6, 10.0, c.friction.smoothing_velocity);
    f.reject_unknown_keys();
  }
  {
    YamlReader m = r.child("mismatch", false);
    c.mismatch.enabled = m.boolean("enabled", c.mismatch.enabled);
    read_mismatch(m, "crank", c.mismatch.crank);
    read_mismatch(m, "coupler", c.mismatch.coupler);
    read_mismatch(m, "plate", c.mismatch.plate);
    m.reject_unknown_keys();
  }
  {
    YamlReader e = r.child("encoder", false);
    c.encoder.enabled = e.boolean("enabled", c.encoder.enabled);
    const int cpr =
        e.integer("counts_per_revolution", static_cast<int>(c.encoder.counts_per_revolution));
    e.require(cpr >= 4, "counts_per_revolution", "must be >= 4", cpr);
    c.encoder.counts_per_revolution = cpr;
    e.reject_unknown_keys();
  }
  {
    YamlReader t = r.child("torque_quantisation", false);
    c.torque_quantisation.enabled = t.boolean("enabled", c.torque_quantisation.enabled);
    c.torque_quantisation.rated_torque =
        t.in_range("rated_torque", 1e-3, 1000.0, c.torque_quantisation.rated_torque);
    t.reject_unknown_keys();
  }
  {
    YamlReader l = r.child("current_loop", false);
    c.current_loop.enabled = l.boolean("enabled", c.current_loop.enabled);
    c.current_loop.time_constant =
        l.in_range("time_constant", 1e-7, 0.1, c.current_loop.time_constant);
    l.reject_unknown_keys();
  }
  {
    YamlReader s = r.child("saturation", false);
    c.saturation.enabled = s.boolean("enabled", c.saturation.enabled);
    c.saturation.peak_torque = s.in_range("peak_torque", 1e-3, 1000.0, c.saturation.peak_torque);
    s.reject_unknown_keys();
  }
  {
    YamlReader d = r.child("transport_delay", false);
    c.transport_delay.enabled = d.boolean("enabled", c.transport_delay.enabled);
    c.transport_delay.cycles = d.integer("cycles", c.transport_delay.cycles);
    d.require(c.transport_delay.cycles >= 1 && c.transport_delay.cycles <= kMaxDelayCycles,
              "cycles", fmt::format("must be in [1, {}]", kMaxDelayCycles),
              c.transport_delay.cycles);
    d.reject_unknown_keys();
  }
  r.reject_unknown_keys();
  problems.finish();
  return c;
}

PlantConfig load_plant_config_file(const std::string& path) {
  const YAML::Node root = YamlReader::load_file(path);
  return load_plant_config(root["plant"]);
}

}  // namespace dualv::sim
