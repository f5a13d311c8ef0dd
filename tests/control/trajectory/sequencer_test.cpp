// control/trajectory/sequencer.hpp: Cartesian and joint references through the model.
#include "control/trajectory/sequencer.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "control/model/kinematics.hpp"
#include "test_util.hpp"

namespace dualv::trajectory {
namespace {

using test::dualv_model;
using test::kHome;
using test::max_diff;
using test::paper_program;

std::vector<double> joint_times(const Program& p) {
  std::vector<double> out;
  for (const Segment& s : p.segments()) {
    out.push_back(s.t_start);
    if (s.kind == SegmentKind::kShape) {
      out.push_back(s.t_start + s.motion.timing.tau);
      out.push_back(s.t_start + s.duration() - s.motion.timing.tau);
    }
  }
  out.push_back(p.duration());
  return out;
}

TEST(Sequencer, JointReferencesAreTheIkOfTheCartesianSamples) {
  const model::Model& m = dualv_model();
  Sequencer seq(m, paper_program());
  model::Data data(m);
  model::JointVector q;
  Reference r;
  int n = 0;
  for (double t = 0; t < seq.duration(); t += 0.0011, ++n) {
    ASSERT_EQ(seq.sample(t, r), SampleStatus::kOk) << t;
    ASSERT_EQ(model::inverse_kinematics(m, data, r.cartesian.X, q), model::Status::kOk);
    ASSERT_EQ(r.q.size(), m.n);
    EXPECT_LT(max_diff(r.q, q), 1e-12) << t;
    EXPECT_EQ(r.segment, seq.program().segment_at(t));
    EXPECT_EQ(r.t, t);
  }
  EXPECT_GT(n, 3000);
}

TEST(Sequencer, JointVelocityAndAccelerationMatchFiniteDifferences) {
  for (auto kind : {TimingKind::kRetimed, TimingKind::kSmooth, TimingKind::kOriginal}) {
    Sequencer seq(dualv_model(), with_timing(paper_program(), kind));
    const std::vector<double> joints = joint_times(seq.program());
    const double h = 1e-6;
    Reference r, rp, rm;
    for (double t = 0.0009; t < seq.duration(); t += 0.0017) {
      bool near = false;
      for (double tj : joints) near |= std::abs(t - tj) < 3 * h;
      if (near) continue;
      ASSERT_EQ(seq.sample(t + h, rp), SampleStatus::kOk);
      ASSERT_EQ(seq.sample(t - h, rm), SampleStatus::kOk);
      ASSERT_EQ(seq.sample(t, r), SampleStatus::kOk);
      const double s = 1 + r.q_dd.cwiseAbs().maxCoeff();
      EXPECT_LT(max_diff(r.q_dot, (rp.q - rm.q) / (2 * h)), 1e-7 * s) << to_string(kind) << t;
      EXPECT_LT(max_diff(r.q_dd, (rp.q_dot - rm.q_dot) / (2 * h)), 1e-5 * s)
          << to_string(kind) << t;
    }
  }
}

TEST(Sequencer, JointReferencesAreContinuousAcrossJoins) {
  Sequencer seq(dualv_model(), paper_program());
  Reference a, b;
  for (const Segment& s : seq.program().segments()) {
    ASSERT_NE(seq.sample(std::nextafter(s.t_start, -1e300), a), SampleStatus::kKinematicsFailed);
    ASSERT_EQ(seq.sample(s.t_start, b), SampleStatus::kOk);
    EXPECT_LT(max_diff(a.q, b.q), 1e-9) << s.label;
    EXPECT_LT(max_diff(a.q_dot, b.q_dot), 1e-9) << s.label;
    EXPECT_LT(max_diff(a.q_dd, b.q_dd), 1e-9) << s.label;
  }
}

TEST(Sequencer, OriginalClockJointReferencesJump) {
  Sequencer seq(dualv_model(), with_timing(paper_program(), TimingKind::kOriginal));
  Reference a, b;
  const Segment& circle = seq.program().segments()[1];
  seq.sample(std::nextafter(circle.t_start, -1e300), a);
  seq.sample(circle.t_start, b);
  EXPECT_GT(max_diff(a.q_dot, b.q_dot), 0.1);
  EXPECT_GT(max_diff(a.q_dd, b.q_dd), 1.0);
}

TEST(Sequencer, ReportsPhaseAndSegment) {
  Sequencer seq(dualv_model(), paper_program());
  const Segment& circle = seq.program().segments()[1];
  Reference r;
  ASSERT_EQ(seq.sample(circle.t_start + 0.25, r), SampleStatus::kOk);
  EXPECT_EQ(r.segment, 1u);
  EXPECT_EQ(r.kind, SegmentKind::kShape);
  EXPECT_NEAR(r.phase.lambda, std::numbers::pi, 1e-12);
  EXPECT_NEAR(r.phase.lambda_dot, 2 * std::numbers::pi / 0.4, 1e-9);
  EXPECT_EQ(r.phase.lambda_dd, 0.0);
  ASSERT_EQ(seq.sample(0.1, r), SampleStatus::kOk);
  EXPECT_EQ(r.kind, SegmentKind::kPtp);
  EXPECT_EQ(r.phase.lambda, 0.0);
}

TEST(Sequencer, CartesianOnlySamplingMatchesTheProgram) {
  Sequencer seq(dualv_model(), paper_program());
  Reference r;
  CartesianSample c;
  PhaseSample ph;
  for (double t = 0; t < seq.duration(); t += 0.013) {
    ASSERT_EQ(seq.sample_cartesian(t, r), SampleStatus::kOk);
    seq.program().sample(t, c, ph);
    EXPECT_EQ(r.cartesian.X, c.X);
    EXPECT_EQ(r.cartesian.X_dd, c.X_dd);
  }
}

TEST(Sequencer, StatusAfterTheEndAndForBadTime) {
  Sequencer seq(dualv_model(), paper_program());
  Reference r;
  EXPECT_EQ(seq.sample(seq.duration() + 1.0, r), SampleStatus::kFinished);
  EXPECT_LT(max_diff(r.cartesian.X, kHome), 1e-12);
  EXPECT_EQ(r.q_dot.norm(), 0.0);
  r.t = 42.0;
  EXPECT_EQ(seq.sample(NAN, r), SampleStatus::kInvalidTime);
  EXPECT_EQ(seq.sample(INFINITY, r), SampleStatus::kInvalidTime);
  EXPECT_EQ(r.t, 42.0);  // nothing written
  EXPECT_STREQ(to_string(SampleStatus::kKinematicsFailed), "kinematics failed");
}

TEST(Sequencer, UnreachablePoseReportsKinematicsFailure) {
  Program p(kHome);
  p.add_ptp(Pose(0.0, 1.2, 0.0), 1.0);  // far beyond l1 + l2 from every base pivot
  Sequencer seq(dualv_model(), p);
  Reference r;
  ASSERT_EQ(seq.sample(0.0, r), SampleStatus::kOk);
  const model::JointVector q_ok = r.q;
  EXPECT_EQ(seq.sample(1.0, r), SampleStatus::kKinematicsFailed);
  EXPECT_NE(r.model_status, model::Status::kOk);
  EXPECT_EQ(r.q, q_ok);  // joint refs stale, not garbage
  EXPECT_TRUE(r.q.allFinite());
}

}  // namespace
}  // namespace dualv::trajectory
