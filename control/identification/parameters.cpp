#include "control/identification/parameters.hpp"

#include <fmt/format.h>

namespace dualv::identification {

namespace {

const char* body_parameter_name(int p) {
  static const char* names[] = {"ZZ", "MX", "MY", "M"};
  return names[p];
}

const char* body_parameter_unit(int p) {
  static const char* units[] = {"kg m^2", "kg m", "kg m", "kg"};
  return units[p];
}

void put_body(const model::Body& b, Eigen::VectorXd& phi, int first) {
  phi[first + static_cast<int>(BodyParameter::kZZ)] = b.inertia + b.mass * b.com.squaredNorm();
  phi[first + static_cast<int>(BodyParameter::kMX)] = b.mass * b.com.x();
  phi[first + static_cast<int>(BodyParameter::kMY)] = b.mass * b.com.y();
  phi[first + static_cast<int>(BodyParameter::kM)] = b.mass;
}

model::Body get_body(const Eigen::VectorXd& phi, int first) {
  model::Body b;
  b.mass = phi[first + static_cast<int>(BodyParameter::kM)];
  if (b.mass > 0.0)
    b.com = model::Vec2(phi[first + static_cast<int>(BodyParameter::kMX)],
                        phi[first + static_cast<int>(BodyParameter::kMY)]) /
            b.mass;
  b.inertia = phi[first + static_cast<int>(BodyParameter::kZZ)] - b.mass * b.com.squaredNorm();
  return b;
}

}  // namespace

std::string ParameterLayout::name(int index) const {
  const int bodies = kParametersPerBody * (2 * n + 1);
  if (index < bodies) {
    const int body = index / kParametersPerBody, p = index % kParametersPerBody;
    if (body < n) return fmt::format("crank{}.{}", body + 1, body_parameter_name(p));
    if (body < 2 * n) return fmt::format("coupler{}.{}", body - n + 1, body_parameter_name(p));
    return fmt::format("plate.{}", body_parameter_name(p));
  }
  const int j = index - bodies;
  return j < n ? fmt::format("joint{}.Fv", j + 1) : fmt::format("joint{}.Fc", j - n + 1);
}

std::string ParameterLayout::unit(int index) const {
  const int bodies = kParametersPerBody * (2 * n + 1);
  if (index < bodies) return body_parameter_unit(index % kParametersPerBody);
  return index - bodies < n ? "N m s/rad" : "N m";
}

Eigen::VectorXd standard_parameters(const model::Model& model, const JointFriction& friction) {
  const ParameterLayout L{model.n};
  Eigen::VectorXd phi = Eigen::VectorXd::Zero(L.size());
  for (int i = 0; i < model.n; ++i) {
    put_body(model.chains[i].crank, phi, L.crank(i, BodyParameter::kZZ));
    put_body(model.chains[i].coupler, phi, L.coupler(i, BodyParameter::kZZ));
    phi[L.viscous(i)] = friction.viscous;
    phi[L.coulomb(i)] = friction.coulomb;
  }
  put_body(model.plate, phi, L.plate(BodyParameter::kZZ));
  return phi;
}

model::Model model_with_parameters(const model::Model& geometry, const Eigen::VectorXd& phi) {
  const ParameterLayout L{geometry.n};
  model::Model m = geometry;
  for (int i = 0; i < m.n; ++i) {
    m.chains[i].crank = get_body(phi, L.crank(i, BodyParameter::kZZ));
    m.chains[i].coupler = get_body(phi, L.coupler(i, BodyParameter::kZZ));
  }
  m.plate = get_body(phi, L.plate(BodyParameter::kZZ));
  return m;
}

}  // namespace dualv::identification
