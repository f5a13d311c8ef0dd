// The program loader and pre-flight (control/trajectory/program.hpp, preflight.hpp) on any
// YAML: the input is a program file (config/paper.yaml and variants are the seeds), loaded
// against the shipped model and limits as `dualv run` does. A refusal is an exception;
// nothing may crash, leak or hit undefined behaviour, and a program that loads must be what
// program.hpp says: finite, segments back to back in time, each starting where the previous
// one ends, each sampled at its ends at its declared start and end poses.
//
// Work per input is bounded: programs longer than kMaxCheckedSeconds are loaded without the
// workspace check and not pre-flighted (both sample every 0.5 ms, so their cost grows with the
// duration; refusing absurd durations is issue 14 defect 3's, not the fuzzer's).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <string>

#include <yaml-cpp/yaml.h>

#include "apps/experiment/robot_config.hpp"
#include "control/trajectory/preflight.hpp"
#include "control/trajectory/program.hpp"

#include "fuzz/check.hpp"

namespace tr = dualv::trajectory;

namespace {

constexpr double kMaxCheckedSeconds = 2.0;

const dualv::apps::RobotConfig& robot() {
  static const dualv::apps::RobotConfig cfg =
      dualv::apps::load_robot_config(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  return cfg;
}

bool near(const tr::Pose& a, const tr::Pose& b) {
  for (int k = 0; k < 3; ++k)
    if (!(std::abs(a[k] - b[k]) <= 1e-9 * (1.0 + std::abs(a[k]) + std::abs(b[k])))) return false;
  return true;
}

void check_program(const tr::Program& p) {
  FUZZ_CHECK(std::isfinite(p.duration()) && p.duration() >= 0.0);
  double t = 0.0;
  tr::Pose end = p.start_pose();
  for (const tr::Segment& s : p.segments()) {
    FUZZ_CHECK(std::isfinite(s.duration()) && s.duration() >= 0.0);
    FUZZ_CHECK(std::abs(s.t_start - t) <= 1e-9 * (1.0 + t));
    FUZZ_CHECK(near(s.start_pose(), end));
    tr::CartesianSample c;
    tr::PhaseSample ph;
    s.sample(0.0, c, ph);
    FUZZ_CHECK(c.X.allFinite() && near(c.X, s.start_pose()));
    s.sample(s.duration(), c, ph);
    FUZZ_CHECK(c.X.allFinite() && near(c.X, s.end_pose()));
    t += s.duration();
    end = s.end_pose();
  }
  FUZZ_CHECK(std::abs(p.duration() - t) <= 1e-9 * (1.0 + t));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const dualv::apps::RobotConfig& cfg = robot();
  tr::ProgramContext ctx;
  ctx.start = ctx.home = cfg.model.home;
  try {
    const YAML::Node root = YAML::Load(std::string(reinterpret_cast<const char*>(data), size));
    if (!root.IsMap()) return 0;
    const tr::Program loose = tr::load_program(root["program"], ctx);
    check_program(loose);
    if (loose.duration() > kMaxCheckedSeconds) return 0;
    ctx.workspace = cfg.trajectory.limits.workspace;
    const tr::Program program = tr::load_program(root["program"], ctx);
    check_program(program);
    const tr::PreflightReport report = tr::preflight(cfg.model, program, cfg.trajectory.limits);
    if (report.ok()) {
      FUZZ_CHECK(report.max_joint_speed <= cfg.trajectory.limits.max_joint_speed);
      FUZZ_CHECK(report.max_joint_torque <= cfg.trajectory.limits.max_joint_torque);
    }
  } catch (const std::exception&) {
    // refused, with a message (set-up code)
  }
  return 0;
}
