// Base parameters of the Dual-V: their number and their combinations against the closed forms
// of the coupler's two-point-mass split (control/model/dynamics.hpp chain_inertia), and
// W phi = W_1 phi_b at states the QR never saw.
#include "control/identification/base_parameters.hpp"

#include <gtest/gtest.h>

#include <random>

#include "control/config/model_config.hpp"
#include "control/identification/regressor.hpp"

namespace dualv::identification {
namespace {

model::Model dual_v() {
  return model::load_model_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
}

double coefficient(const BaseParameters& b, int base_index, int standard_index) {
  for (std::size_t k = 0; k < b.dependent.size(); ++k)
    if (b.dependent[k] == standard_index) return b.beta(base_index, static_cast<Eigen::Index>(k));
  return 0.0;
}

int base_index_of(const BaseParameters& b, int standard_index) {
  for (int j = 0; j < b.size(); ++j)
    if (b.independent[static_cast<std::size_t>(j)] == standard_index) return j;
  return -1;
}

TEST(BaseParameters, DualVHas24AndTheirCombinationsAreTheCouplerSplit) {
  const model::Model m = dual_v();
  const BaseParameters b = find_base_parameters(m);
  // Per chain: crank inertia about the motor axis, coupler rotary inertia, coupler off-axis
  // moment; the plate's mass, first moments and inertia; viscous and Coulomb friction per joint.
  EXPECT_EQ(b.size(), 3 * m.n + 4 + 2 * m.n);
  const ParameterLayout L{m.n};
  using P = BodyParameter;
  for (int i = 0; i < m.n; ++i) {
    const double l1 = m.chains[i].crank_length, l2 = m.chains[i].coupler_length;
    const model::Vec2 c = m.chains[i].plate_anchor;
    const int crank = base_index_of(b, L.crank(i, P::kZZ));
    ASSERT_GE(crank, 0);
    // The coupler's elbow share m_B = M - MX / l2 turns with the crank tip, l1 from the axis.
    EXPECT_NEAR(coefficient(b, crank, L.coupler(i, P::kM)), l1 * l1, 1e-9);
    EXPECT_NEAR(coefficient(b, crank, L.coupler(i, P::kMX)), -l1 * l1 / l2, 1e-9);
    // Its anchor share m_C = MX / l2 rides on the plate at c_i.
    const int pm = base_index_of(b, L.plate(P::kM)), pmx = base_index_of(b, L.plate(P::kMX)),
              pzz = base_index_of(b, L.plate(P::kZZ));
    EXPECT_NEAR(coefficient(b, pm, L.coupler(i, P::kMX)), 1.0 / l2, 1e-9);
    EXPECT_NEAR(coefficient(b, pmx, L.coupler(i, P::kMX)), c.x() / l2, 1e-9);
    EXPECT_NEAR(coefficient(b, pzz, L.coupler(i, P::kMX)), c.squaredNorm() / l2, 1e-9);
    // Rotary inertia J = ZZ - l2 MX (I - m d (l2 - d) for a centre of mass on the axis).
    const int cz = base_index_of(b, L.coupler(i, P::kZZ));
    ASSERT_GE(cz, 0);
    EXPECT_NEAR(coefficient(b, cz, L.coupler(i, P::kMX)), -l2, 1e-9);
  }
  // Without gravity a crank's mass and first moments never act.
  EXPECT_EQ(b.inert().size(), static_cast<std::size_t>(3 * m.n));
}

TEST(BaseParameters, ReproduceTheFullRegressorAtNewStatesForAnyParameters) {
  for (bool gravity : {false, true}) {
    model::Model m = dual_v();
    if (gravity) m.gravity = model::Vec2(0.0, -9.81);
    const BaseParameters b = find_base_parameters(m);
    if (gravity) {
      EXPECT_GT(b.size(), 24);  // the cranks' first moments act against gravity
    }
    std::mt19937_64 rng(99);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Eigen::VectorXd phi(b.layout.size());
    for (Eigen::Index k = 0; k < phi.size(); ++k) phi[k] = u(rng);  // not even physical
    const Eigen::VectorXd phi_b = b.from_standard(phi);
    model::Data data(m);
    RegressorRows W;
    int checked = 0;
    for (int k = 0; k < 100; ++k) {
      const model::Pose X = m.home + model::Pose(0.07 * u(rng), 0.07 * u(rng), 0.25 * u(rng));
      if (regressor(m, data, X, model::Twist(u(rng), u(rng), 3 * u(rng)),
                    model::Twist(9 * u(rng), 9 * u(rng), 40 * u(rng)), W) != model::Status::kOk)
        continue;
      const Eigen::Vector3d full = W * phi;
      const Eigen::Vector3d reduced = b.columns(W) * phi_b;
      EXPECT_LT((full - reduced).norm(), 1e-9 * std::max(1.0, full.norm())) << k;
      ++checked;
    }
    EXPECT_GT(checked, 80);
    // to_standard: a standard vector with these base parameters, the rest from a reference.
    const Eigen::VectorXd back = b.to_standard(phi_b, Eigen::VectorXd::Zero(phi.size()));
    EXPECT_LT((b.from_standard(back) - phi_b).norm(), 1e-9);
  }
}

}  // namespace
}  // namespace dualv::identification
