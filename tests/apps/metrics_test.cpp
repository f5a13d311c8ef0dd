// compute_metrics (apps/experiment/closed_loop.hpp) on rows written by hand: the per-shape
// windows, the shapes together and the whole program (issue 15: the ringing after a shape is
// outside its window and must still be reported).
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>

#include "apps/experiment/closed_loop.hpp"
#include "control/trajectory/program.hpp"

namespace dualv::apps {
namespace {

trajectory::Program program() {
  trajectory::ProgramContext ctx;
  ctx.start = ctx.home = model::Pose(0.0, 0.25, 0.0);
  return trajectory::load_program(YAML::Load(R"(
segments:
  - ptp: {duration: 0.3}
  - shape: {type: circle, T: 0.5, timing: retimed, tau: 0.1}
  - dwell: {duration: 0.2}
)"),
                                  ctx);
}

// A row of segment `s` at time t with tracking error (ex, ey) [mm] and torque `tau` on motor 1.
Row row(double t, int s, double ex_mm, double ey_mm, double tau = 0.0) {
  Row r;
  r.t = t;
  r.segment = s;
  r.X_d = model::Pose(0.0, 0.25, 0.0);
  r.X = r.X_d - model::Pose(ex_mm * 1e-3, ey_mm * 1e-3, 0.0);
  r.tau[0] = tau;
  return r;
}

TEST(Metrics, WholeProgramKeepsWhatTheShapeWindowsLeaveOut) {
  RunResult r;
  r.n = 4;
  r.rows = {
      row(0.0, 0, 0.1, 0.0, 0.0),   // ptp
      row(0.5, 1, 0.3, 0.4, 1.0),   // circle: |e| = 0.5
      row(0.6, 1, -0.6, 0.0, 3.0),  // circle: |ex| = 0.6, step 2
      row(0.9, 2, 0.0, -0.8, 0.0),  // dwell after the circle: the ringing, |ey| = 0.8, step 3
  };
  compute_metrics(program(), r);
  ASSERT_EQ(r.segments.size(), 3u);
  const SegmentMetrics& circle = r.segments[1];
  EXPECT_EQ(circle.label, "circle");
  EXPECT_EQ(circle.cycles, 2);
  EXPECT_NEAR(circle.max_error_x_mm, 0.6, 1e-9);
  EXPECT_NEAR(circle.max_error_y_mm, 0.4, 1e-9);
  EXPECT_DOUBLE_EQ(circle.t_max_error_y, 0.5);
  EXPECT_NEAR(circle.rms_error_mm, std::sqrt((0.25 + 0.36) / 2), 1e-9);
  // The shapes together are the circle alone; the ringing at t = 0.9 s is not in it.
  EXPECT_NEAR(r.shapes.max_error_mm, 0.6, 1e-9);
  EXPECT_NEAR(r.shapes.max_error_y_mm, 0.4, 1e-9);
  // The whole program sees all four rows.
  EXPECT_EQ(r.program.cycles, 4);
  EXPECT_NEAR(r.program.max_error_y_mm, 0.8, 1e-9);
  EXPECT_DOUBLE_EQ(r.program.t_max_error_y, 0.9);
  EXPECT_NEAR(r.program.max_error_x_mm, 0.6, 1e-9);
  EXPECT_DOUBLE_EQ(r.program.t_max_error_x, 0.6);
  EXPECT_NEAR(r.program.max_error_mm, 0.8, 1e-9);
  EXPECT_DOUBLE_EQ(r.program.t_max_error, 0.9);
  EXPECT_NEAR(r.program.rms_error_mm, std::sqrt((0.01 + 0.25 + 0.36 + 0.64) / 4), 1e-9);
  EXPECT_DOUBLE_EQ(r.program.max_tau_step, 3.0);  // 3 N m -> 0 N m, across the window edge
  EXPECT_DOUBLE_EQ(r.program.peak_tau[0], 3.0);
}

}  // namespace
}  // namespace dualv::apps
