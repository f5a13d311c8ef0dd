// `dualv model`: the mechanism at a pose, for checking a configuration by eye.
#include <fmt/core.h>
#include <fmt/ranges.h>

#include <Eigen/Core>
#include <sstream>
#include <string>
#include <vector>

#include "apps/commands.hpp"
#include "apps/config_path.hpp"
#include "control/config/model_config.hpp"
#include "control/model/dynamics.hpp"
#include "control/model/kinematics.hpp"

namespace dualv::apps {

namespace {

std::string matrix_text(const Eigen::MatrixXd& m, int indent) {
  std::ostringstream os;
  const Eigen::IOFormat fmt(6, 0, "  ", "\n" + std::string(indent, ' '), "[", "]");
  os << std::string(indent, ' ') << m.format(fmt);
  return os.str();
}

void print_model(const std::string& config, const std::vector<double>& pose_arg) {
  const model::Model m = model::load_model_file(config);
  model::Data data(m);
  model::Pose X = m.home;
  if (!pose_arg.empty()) X = model::Pose(pose_arg[0], pose_arg[1], pose_arg[2]);
  fmt::print("config: {}\nchains: {}\npose X = [x {:.6f} m, y {:.6f} m, theta {:.6f} rad]{}\n",
             config, m.n, X.x(), X.y(), X.z(), pose_arg.empty() ? " (home)" : "");
  model::Status s = model::update_kinematics(m, data, X, model::Twist::Zero());
  if (s == model::Status::kOk) s = model::update_dynamics(m, data, X, model::Twist::Zero());
  if (s != model::Status::kOk) {
    fmt::print("inside workspace: no ({})\n", model::to_string(s));
    exit_code() = 3;
    return;
  }
  model::update_projectors(m, data);
  const auto sm = model::singularity_measures(m, data);
  const Eigen::Vector3d sv = model::jacobian_singular_values(data);
  fmt::print("inside workspace: yes\n");
  fmt::print("q [rad]: {::.6f}\n", std::vector<double>(data.q.data(), data.q.data() + m.n));
  fmt::print("Jm (q_dot = Jm X_dot):\n{}\n", matrix_text(data.Jm, 2));
  fmt::print("singular values of Jm: {:.4f} {:.4f} {:.4f}\n", sv[0], sv[1], sv[2]);
  fmt::print("distance to parallel singularity (scaled sigma_min): {:.4f}\n", sm.parallel);
  fmt::print("serial singularity measure |sin(crank, coupler)| per chain: {::.4f}\n",
             std::vector<double>(sm.serial.begin(), sm.serial.begin() + m.n));
  fmt::print("M(X) task-space mass matrix:\n{}\n", matrix_text(data.M, 2));
}

}  // namespace

void register_model_command(CLI::App& app) {
  auto* cmd = app.add_subcommand("model", "Show q, Jm, singular values and M(X) at a pose");
  static std::string config;
  static std::vector<double> pose;
  add_config_option(*cmd, config);
  cmd->add_option("--pose", pose, "Plate pose x y theta [m m rad] (default: home)")->expected(3);
  cmd->callback([] { print_model(resolve_config(config), pose); });
}

}  // namespace dualv::apps
