#include "control/config/model_config.hpp"

#include <fmt/format.h>

#include "common/yaml_reader.hpp"
#include "control/model/kinematics.hpp"

namespace dualv::model {

namespace {

// Physical ranges (model_config.hpp): catch unit mistakes (mm for m, g for kg).
constexpr double kMaxLength = 5.0;     // [m]
constexpr double kMaxMass = 1000.0;    // [kg]
constexpr double kMaxInertia = 100.0;  // [kg m^2]
constexpr double kMaxGravity = 20.0;   // [m/s^2]

Vec2 read_vec2(YamlReader& r, const std::string& key, std::optional<Vec2> fallback = {}) {
  std::optional<std::vector<double>> fb;
  if (fallback) fb = std::vector<double>{fallback->x(), fallback->y()};
  const auto v = r.numbers(key, fb);
  if (v.size() != 2) {
    r.problem(
        fmt::format("{}: must be a list of 2 numbers [x, y] (got {})", r.key_path(key), v.size()));
    return Vec2::Zero();
  }
  return {v[0], v[1]};
}

struct LinkParams {
  double length = 0.0;
  Body body;
};

// Reads a link block; `defaults` (from model.crank / model.coupler) fill keys a
// chain does not override.
// A chain's override block gives only the keys it changes: those are read when present
// (never through a fallback, so a complete-file load does not ask for every key there).
LinkParams read_link(YamlReader r, const LinkParams* defaults) {
  LinkParams p = defaults ? *defaults : LinkParams{};
  auto given = [&](const char* key) { return !defaults || r.has(key); };
  if (given("length")) p.length = r.in_range("length", 1e-3, kMaxLength);
  if (given("mass")) p.body.mass = r.in_range("mass", 0.0, kMaxMass);
  if (given("inertia")) p.body.inertia = r.in_range("inertia", 0.0, kMaxInertia);
  if (!defaults)
    p.body.com = read_vec2(r, "com", Vec2::Zero());
  else if (r.has("com"))
    p.body.com = read_vec2(r, "com");
  r.reject_unknown_keys();
  return p;
}

}  // namespace

Model load_model(const YAML::Node& model_node) {
  ConfigProblems problems;
  YamlReader r(model_node, "model", problems.sink());
  if (!r.valid()) {
    problems.sink()->push_back("model: missing (a map describing the mechanism)");
    problems.finish();
  }
  Model m;
  m.gravity = read_vec2(r, "gravity", Vec2::Zero());
  r.require(m.gravity.norm() <= kMaxGravity, "gravity",
            fmt::format("must have a norm <= {} m/s^2", kMaxGravity), m.gravity.norm());
  {
    const auto home = r.numbers("home");
    if (home.size() == 3)
      m.home = Pose(home[0], home[1], home[2]);
    else
      r.problem(fmt::format("model.home: must be a list of 3 numbers [x, y, theta] (got {})",
                            home.size()));
  }
  m.characteristic_length = r.in_range("characteristic_length", 1e-3, kMaxLength, 0.11);
  const LinkParams crank = read_link(r.child("crank"), nullptr);
  const LinkParams coupler = read_link(r.child("coupler"), nullptr);
  {
    YamlReader plate = r.child("plate");
    m.plate.mass = plate.in_range("mass", 0.0, kMaxMass);
    m.plate.inertia = plate.in_range("inertia", 0.0, kMaxInertia);
    m.plate.com = read_vec2(plate, "com", Vec2::Zero());
    plate.reject_unknown_keys();
  }
  auto chains = r.children("chains");
  if (chains.size() < 3 || chains.size() > static_cast<std::size_t>(kMaxChains)) {
    r.problem(fmt::format("model.chains: a planar n-RRR machine needs 3 to {} chains (got {})",
                          kMaxChains, chains.size()));
  } else {
    m.n = static_cast<int>(chains.size());
    for (std::size_t i = 0; i < chains.size(); ++i) {
      YamlReader& c = chains[i];
      Chain& ch = m.chains[i];
      ch.base = read_vec2(c, "base");
      ch.plate_anchor = read_vec2(c, "anchor");
      ch.working_mode = c.integer("working_mode");
      c.require(ch.working_mode == 1 || ch.working_mode == -1, "working_mode", "must be +1 or -1",
                ch.working_mode);
      const LinkParams cr = c.has("crank") ? read_link(c.child("crank"), &crank) : crank;
      const LinkParams co = c.has("coupler") ? read_link(c.child("coupler"), &coupler) : coupler;
      ch.crank_length = cr.length;
      ch.crank = cr.body;
      ch.coupler_length = co.length;
      ch.coupler = co.body;
      c.reject_unknown_keys();
    }
  }
  r.reject_unknown_keys();
  problems.finish();

  // Whole-model checks, once every value is known to be well-formed.
  Data data(m);
  const Status s = update_kinematics(m, data, m.home, Twist::Zero());
  if (s != Status::kOk) {
    problems.sink()->push_back(fmt::format(
        "model.home: the home pose [{}, {}, {}] is not usable: {} (check chains, lengths, home)",
        m.home.x(), m.home.y(), m.home.z(), to_string(s)));
  } else if (update_projectors(m, data) != Status::kOk ||
             singularity_measures(m, data).parallel < 1e-3) {
    problems.sink()->push_back(
        fmt::format("model.home: the home pose [{}, {}, {}] is at or near a parallel singularity",
                    m.home.x(), m.home.y(), m.home.z()));
  } else if (const auto sm = singularity_measures(m, data); sm.min_serial < 1e-3) {
    problems.sink()->push_back(
        fmt::format("model.home: the home pose [{}, {}, {}] is at or near a serial singularity",
                    m.home.x(), m.home.y(), m.home.z()));
  }
  problems.finish();
  return m;
}

Model load_model_file(const std::string& path) {
  const YAML::Node root = YamlReader::load_file(path);
  return load_model(root["model"]);
}

}  // namespace dualv::model
