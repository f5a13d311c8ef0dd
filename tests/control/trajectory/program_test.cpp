// control/trajectory/program.hpp: programs, their YAML, joins, retiming and rebasing.
#include "control/trajectory/program.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <limits>
#include <numbers>
#include <random>
#include <string>

#include "common/config_error.hpp"
#include "test_util.hpp"

namespace dualv::trajectory {
namespace {

using test::home_context;
using test::kHome;
using test::load_yaml;
using test::max_diff;
using test::paper_program;

constexpr double kTwoPi = 2 * std::numbers::pi;

struct Jumps {
  double x = 0, v = 0, a = 0;
  double allowance_v = 0, allowance_a = 0;  // what one ulp of t can explain: ulp * |next deriv|
};

// Difference between the left and right limits of the program's sample at t.
Jumps jumps_at(const Program& p, double t) {
  CartesianSample l, r;
  PhaseSample ph;
  p.sample(std::nextafter(t, -1e300), l, ph);
  p.sample(t, r, ph);
  const double ulp = 4 * (std::nextafter(std::abs(t), 1e300) - std::abs(t));
  return {max_diff(l.X, r.X), max_diff(l.X_dot, r.X_dot), max_diff(l.X_dd, r.X_dd),
          ulp * (l.X_dd.cwiseAbs().maxCoeff() + r.X_dd.cwiseAbs().maxCoeff()),
          ulp * (l.X_ddd.cwiseAbs().maxCoeff() + r.X_ddd.cwiseAbs().maxCoeff())};
}

// Expects load_yaml(text) to throw a ConfigError whose message contains every fragment.
void expect_error(const std::string& text, std::initializer_list<std::string> fragments,
                  ProgramContext ctx = home_context()) {
  try {
    load_yaml(text, ctx);
    ADD_FAILURE() << "no ConfigError for:\n" << text;
  } catch (const ConfigError& e) {
    for (const auto& f : fragments)
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << "missing '" << f << "' in:\n"
                                                                  << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// The paper program

TEST(Program, LoadsThePaperExperiment) {
  const Program p = paper_program();
  ASSERT_EQ(p.size(), 13u);
  EXPECT_LT(max_diff(p.start_pose(), kHome), 1e-15);
  EXPECT_LT(max_diff(p.end_pose(), kHome), 1e-15);
  int shapes = 0;
  double total = 0;
  for (const Segment& s : p.segments()) {
    EXPECT_NEAR(s.t_start, total, 1e-12);
    total += s.duration();
    if (s.kind != SegmentKind::kShape) continue;
    ++shapes;
    EXPECT_EQ(s.motion.timing.kind, TimingKind::kRetimed);
    EXPECT_EQ(s.motion.timing.T, 0.5);
    EXPECT_EQ(s.motion.timing.tau, 0.1);
    EXPECT_LT(max_diff(s.start_pose(), s.end_pose()), 1e-12) << s.label << " is closed";
  }
  EXPECT_EQ(shapes, 4);
  EXPECT_NEAR(p.duration(), total, 1e-12);
  EXPECT_NE(p.segments()[1].label.find("program.segments[1] (shape circle)"), std::string::npos);
}

TEST(Program, PaperExperimentStaysInTheConfiguredWorkspace) {
  ProgramContext ctx = home_context();
  ctx.workspace = test::dualv_trajectory_config().limits.workspace;
  EXPECT_NO_THROW(load_program_file(test::source_path("config/paper.yaml"), ctx));
}

TEST(Program, RetimedJoinsAreContinuousAndShapesStartAndEndAtRest) {
  const Program p = paper_program();
  for (const Segment& s : p.segments()) {
    const Jumps j = jumps_at(p, s.t_start);
    EXPECT_LT(j.x, 1e-9) << s.label;
    EXPECT_LT(j.v, 1e-9) << s.label;
    EXPECT_LT(j.a, 1e-9) << s.label;
    if (s.kind != SegmentKind::kShape) continue;
    CartesianSample c;
    PhaseSample ph;
    for (double t : {0.0, s.duration()}) {
      s.sample(t, c, ph);
      EXPECT_LT(c.X_dot.norm(), 1e-9) << s.label << " t " << t;
      EXPECT_LT(c.X_dd.norm(), 1e-9) << s.label << " t " << t;
    }
  }
  const Jumps end = jumps_at(p, p.duration() + 1e-9);
  EXPECT_LT(end.v + end.a, 1e-9);
}

TEST(Program, OriginalClockShowsThePapersJumps) {
  // eq. 7-8: on the original clock velocity and acceleration step at shape start and end.
  const Program p = with_timing(paper_program(), TimingKind::kOriginal);
  for (const Segment& s : p.segments()) {
    if (s.kind != SegmentKind::kShape) continue;
    const Jumps a = jumps_at(p, s.t_start);
    const Jumps b = jumps_at(p, s.t_start + s.duration());
    EXPECT_LT(a.x + b.x, 1e-9) << s.label;  // the path still joins
    EXPECT_GT(a.a, 0.5) << s.label;         // m/s^2 steps
    EXPECT_GT(b.a, 0.5) << s.label;
    // Velocity steps too, except where the shape starts at a cusp (zero dX/dlambda: the tear
    // point and the deltoid's cusp): there only the acceleration steps. The paper saw the
    // largest errors at the start and end of the circle and the ellipse.
    if (s.label.find("circle") != std::string::npos ||
        s.label.find("ellipse") != std::string::npos) {
      EXPECT_GT(a.v, 0.05) << s.label;  // m/s steps
      EXPECT_GT(b.v, 0.05) << s.label;
    }
  }
}

TEST(Program, RetimedSamplesLieOnTheOriginalCurveAndCoverIt) {
  const Program retimed = paper_program();
  const Program original = with_timing(retimed, TimingKind::kOriginal);
  for (std::size_t k = 0; k < retimed.size(); ++k) {
    const Segment& rs = retimed.segments()[k];
    const Segment& os = original.segments()[k];
    if (rs.kind != SegmentKind::kShape) continue;
    const double T = rs.duration();
    CartesianSample c;
    PhaseSample ph;
    auto orig = [&](double t) {
      os.sample(std::clamp(t, 0.0, T), c, ph);
      return Pose(c.X);
    };
    const int n = 2000;
    std::vector<Pose> curve(n + 1), retimed_pts;
    for (int i = 0; i <= n; ++i) curve[i] = orig(T * i / n);
    double worst = 0;
    for (int i = 0; i <= 500; ++i) {
      rs.sample(T * i / 500, c, ph);
      const Pose x = c.X;
      retimed_pts.push_back(x);
      // Closest point of the original curve: coarse search, then golden-section refinement.
      int best = 0;
      for (int j = 1; j <= n; ++j)
        if ((curve[j] - x).norm() < (curve[best] - x).norm()) best = j;
      // Golden-section refinement around a coarse index; the curve is closed, so a point near
      // its end may be closest to the start sample (and the other way round): try both ends.
      auto refine = [&](int j) {
        // Bracket inside [0, T]: beyond it the clock rests, and a plateau breaks the search.
        double lo = std::max(0.0, T * (j - 1) / n), hi = std::min(T, T * (j + 1) / n);
        const double g = (std::sqrt(5.0) - 1) / 2;
        for (int it = 0; it < 200; ++it) {
          const double m1 = hi - g * (hi - lo), m2 = lo + g * (hi - lo);
          if ((orig(m1) - x).norm() < (orig(m2) - x).norm())
            hi = m2;
          else
            lo = m1;
        }
        return (orig(0.5 * (lo + hi)) - x).norm();
      };
      double d = refine(best);
      if (best == 0) d = std::min(d, refine(n));
      if (best == n) d = std::min(d, refine(0));
      worst = std::max(worst, d);
    }
    EXPECT_LT(worst, 1e-9) << rs.label;
    // Coverage: every point of the original curve is near a retimed sample (closer than the
    // largest step between consecutive retimed samples).
    double step = 0;
    for (std::size_t i = 1; i < retimed_pts.size(); ++i)
      step = std::max(step, (retimed_pts[i] - retimed_pts[i - 1]).norm());
    for (const Pose& q : curve) {
      double d = 1e300;
      for (const Pose& r : retimed_pts) d = std::min(d, (r - q).norm());
      EXPECT_LE(d, step + 1e-12) << rs.label;
    }
  }
}

TEST(Program, TimeDerivativesMatchFiniteDifferences) {
  for (auto kind : {TimingKind::kRetimed, TimingKind::kSmooth, TimingKind::kOriginal}) {
    const Program p = with_timing(paper_program(), kind);
    std::vector<double> joints;
    for (const Segment& s : p.segments()) {
      joints.push_back(s.t_start);
      if (s.kind == SegmentKind::kShape) {
        joints.push_back(s.t_start + s.motion.timing.tau);
        joints.push_back(s.t_start + s.duration() - s.motion.timing.tau);
      }
    }
    joints.push_back(p.duration());
    const double h = 1e-6;
    CartesianSample c, cp, cm;
    PhaseSample ph;
    for (double t = 0.0007; t < p.duration(); t += 0.0013) {
      bool near_joint = false;
      for (double tj : joints) near_joint |= std::abs(t - tj) < 3 * h;
      if (near_joint) continue;
      p.sample(t, c, ph);
      p.sample(t + h, cp, ph);
      p.sample(t - h, cm, ph);
      const double s = 1 + c.X_ddd.cwiseAbs().maxCoeff();
      EXPECT_LT(max_diff(c.X_dot, (cp.X - cm.X) / (2 * h)), 1e-7 * s) << to_string(kind) << t;
      EXPECT_LT(max_diff(c.X_dd, (cp.X_dot - cm.X_dot) / (2 * h)), 1e-6 * s) << t;
      EXPECT_LT(max_diff(c.X_ddd, (cp.X_dd - cm.X_dd) / (2 * h)), 1e-4 * s) << t;
    }
  }
}

TEST(Program, SegmentLookupAndRestOutsideTheProgram) {
  const Program p = paper_program();
  EXPECT_EQ(p.segment_at(-1.0), 0u);
  EXPECT_EQ(p.segment_at(0.0), 0u);
  EXPECT_EQ(p.segment_at(p.segments()[3].t_start), 3u);
  EXPECT_EQ(p.segment_at(std::nextafter(p.segments()[3].t_start, 0.0)), 2u);
  EXPECT_EQ(p.segment_at(1e9), p.size() - 1);
  CartesianSample c;
  PhaseSample ph;
  p.sample(-5.0, c, ph);
  EXPECT_LT(max_diff(c.X, kHome), 1e-15);
  EXPECT_EQ(c.X_dot.norm(), 0.0);
  p.sample(p.duration() + 5.0, c, ph);
  EXPECT_LT(max_diff(c.X, kHome), 1e-15);
  EXPECT_EQ(c.X_dot.norm(), 0.0);
  p.sample(NAN, c, ph);
  EXPECT_LT(max_diff(c.X, kHome), 1e-15);
  EXPECT_TRUE(c.X_dd.allFinite());
  const Program empty(kHome);
  EXPECT_EQ(empty.sample(1.0, c, ph), 0u);
  EXPECT_EQ(c.X, kHome);
}

// ---------------------------------------------------------------------------------------------
// Editing

TEST(Program, WithTimingReplacesEveryShapeLawAndKeepsTheOriginal) {
  const Program p = paper_program();
  const Program o = with_timing(p, TimingKind::kOriginal);
  const Program s = with_timing(o, TimingKind::kSmooth);
  for (std::size_t k = 0; k < p.size(); ++k) {
    if (p.segments()[k].kind != SegmentKind::kShape) continue;
    EXPECT_EQ(p.segments()[k].motion.timing.kind, TimingKind::kRetimed);
    EXPECT_EQ(o.segments()[k].motion.timing.kind, TimingKind::kOriginal);
    EXPECT_EQ(s.segments()[k].motion.timing.kind, TimingKind::kSmooth);
    EXPECT_EQ(s.segments()[k].motion.timing.tau, 0.1);  // kept from the file
  }
  EXPECT_EQ(o.duration(), p.duration());
  // A blended law without a valid tau gets the default fraction of T.
  Program b(make_builtin_shape(BuiltinShape::kCircle, kHome).position(0));
  b.add_shape(make_builtin_shape(BuiltinShape::kCircle, kHome),
              TimingLaw{TimingKind::kOriginal, 0.5, 0.0, 0.0, kTwoPi});
  EXPECT_DOUBLE_EQ(with_timing(b, TimingKind::kRetimed, 0.3).segments()[0].motion.timing.tau, 0.15);
  EXPECT_THROW(with_timing(b, TimingKind::kRetimed, 0.5), ConfigError);
}

TEST(Program, TimingOverrideInTheFile) {
  const Program p = load_yaml(R"(
program:
  timing_override: original
  segments:
    - ptp: {duration: 0.5}
    - shape: {type: circle, T: 0.5, timing: retimed, tau: 0.1}
)",
                              home_context());
  EXPECT_EQ(p.segments()[1].motion.timing.kind, TimingKind::kOriginal);
}

TEST(Program, RebaseReplacesTheStartOfAnOpenFirstMove) {
  const Program p = paper_program();
  const Pose actual(0.03, 0.27, 0.05);
  RebaseOptions o;
  const Program r = rebase(p, actual, o);
  ASSERT_EQ(r.size(), p.size());
  EXPECT_EQ(r.start_pose(), actual);
  EXPECT_EQ(r.segments()[0].ptp.start, actual);
  // Stretched to the rebase limits: the 0.6 s of the file are too short for ~33 mm at 0.05 m/s.
  const double need =
      ptp_min_duration(actual, r.segments()[0].ptp.end, o.max_speed, o.max_acceleration,
                       o.max_angular_speed, o.max_angular_acceleration);
  EXPECT_GT(need, 0.6);
  EXPECT_DOUBLE_EQ(r.segments()[0].duration(), need);
  EXPECT_NEAR(r.duration(), p.duration() + need - 0.6, 1e-12);
  EXPECT_LT(jumps_at(r, r.segments()[1].t_start).v, 1e-9);
  // At home nothing changes.
  EXPECT_DOUBLE_EQ(rebase(p, kHome, o).duration(), p.duration());
}

TEST(Program, RebasePrependsAMoveWhenTheProgramStartsWithAShape) {
  const Program p = load_yaml(R"(
program:
  segments:
    - shape: {type: ellipse, T: 0.5, tau: 0.1}
    - dwell: {duration: 0.1}
)",
                              home_context());
  EXPECT_LT(max_diff(p.start_pose(), Pose(0.02, 0.25, 0)), 1e-15);  // the shape's own start
  const Program r = rebase(p, kHome, RebaseOptions{});
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(r.segments()[0].kind, SegmentKind::kPtp);
  EXPECT_EQ(r.start_pose(), kHome);
  EXPECT_LT(jumps_at(r, r.segments()[1].t_start).x, 1e-12);
  CartesianSample c;
  PhaseSample ph;
  r.sample(0.0, c, ph);
  EXPECT_EQ(c.X, kHome);
  // Already there: nothing added.
  EXPECT_EQ(rebase(p, Pose(0.02, 0.25, 0), RebaseOptions{}).size(), 2u);
}

TEST(Program, BuildersRefuseJumpsAndBadDurations) {
  Program p(kHome);
  EXPECT_THROW(p.add_ptp(kHome, 0.0), ConfigError);
  EXPECT_THROW(p.add_dwell(-1.0), ConfigError);
  const Shape circle = make_builtin_shape(BuiltinShape::kCircle, kHome);
  EXPECT_THROW(p.add_shape(circle, TimingLaw{TimingKind::kRetimed, 0.5, 0.1, 0, kTwoPi}),
               ConfigError);  // starts 15 mm away
  p.add_ptp(circle.position(0), 0.3);
  EXPECT_THROW(p.add_shape(circle, TimingLaw{TimingKind::kRetimed, 0.5, 0.3, 0, kTwoPi}),
               ConfigError);  // tau >= T/2
  p.add_shape(circle, TimingLaw{TimingKind::kRetimed, 0.5, 0.1, 0, kTwoPi});
  EXPECT_EQ(p.size(), 2u);
  EXPECT_THROW(p.set_timing(0, TimingLaw{}), ConfigError);  // not a shape
  p.set_timing(1, TimingLaw{TimingKind::kRetimed, 0.7, 0.1, 0, kTwoPi});
  EXPECT_DOUBLE_EQ(p.duration(), 1.0);
}

TEST(Program, CustomShapeFromYaml) {
  const Program p = load_yaml(R"(
program:
  segments:
    - ptp: {duration: 0.5}
    - shape:
        type: custom
        centre: [0.0, 0.25, 0.0]
        T: 1.0
        timing: smooth
        tau: 0.2
        terms:
          x: [{a: 0.01, alpha: 3, n1: 1}]
          y: [{b: 0.01, beta: 1, n2: 2}, {a: 0.002, alpha: 2, n1: 1}]
          theta: [{b: 0.05, beta: 2, n2: 0.5}]
)",
                              home_context());
  const Segment& s = p.segments()[1];
  EXPECT_EQ(s.motion.timing.kind, TimingKind::kSmooth);
  const Pose x = s.motion.shape.position(0.7);
  EXPECT_NEAR(x.x(), 0.01 * std::pow(std::cos(0.7), 3), 1e-15);
  EXPECT_NEAR(x.y(), 0.25 + 0.01 * std::sin(1.4) + 0.002 * std::pow(std::cos(0.7), 2), 1e-15);
  EXPECT_NEAR(x.z(), 0.05 * std::pow(std::sin(0.35), 2), 1e-15);
}

TEST(Program, LoadFailureLeavesTheCallersProgramUntouched) {
  Program p = paper_program();
  EXPECT_THROW(p = load_yaml("program: {segments: [{dwell: {duration: -1}}]}", home_context()),
               ConfigError);
  EXPECT_EQ(p.size(), 13u);
}

// ---------------------------------------------------------------------------------------------
// YAML errors: each refused with the key that caused it

TEST(ProgramYaml, UnknownShape) {
  expect_error("program: {segments: [{shape: {type: square, T: 0.5, tau: 0.1}}]}",
               {"program.segments[0].shape.type: unknown shape 'square'"});
}

TEST(ProgramYaml, UnknownKeyInShape) {
  expect_error("program: {segments: [{shape: {type: circle, T: 0.5, tau: 0.1, radius: 2}}]}",
               {"program.segments[0].shape.radius: unknown key"});
}

TEST(ProgramYaml, UnknownKeyInSegment) {
  expect_error("program: {segments: [{dwell: {duration: 1}, speed: 3}]}",
               {"program.segments[0].speed: unknown key"});
}

TEST(ProgramYaml, UnknownKeyInProgram) {
  expect_error("program: {segments: [{dwell: {duration: 1}}], loops: 3}",
               {"program.loops: unknown key"});
}

TEST(ProgramYaml, UnknownKeyInTerm) {
  expect_error(R"(
program:
  segments:
    - shape: {type: custom, T: 1, tau: 0.1, terms: {x: [{a: 0.01, gamma: 2}]}}
)",
               {"program.segments[0].shape.terms.x[0].gamma: unknown key"});
}

TEST(ProgramYaml, ScaleOnCustomShapeIsUnknown) {
  expect_error(
      "program: {segments: [{shape: {type: custom, T: 1, tau: 0.1, scale: 2, terms: {}}}]}",
      {"program.segments[0].shape.scale: unknown key"});
}

TEST(ProgramYaml, CustomShapeWithoutTerms) {
  expect_error("program: {segments: [{shape: {type: custom, T: 1, tau: 0.1}}]}",
               {"program.segments[0].shape.terms: missing"});
}

TEST(ProgramYaml, ZeroDuration) {
  expect_error("program: {segments: [{shape: {type: circle, T: 0, tau: 0.1}}]}",
               {"program.segments[0].shape.T: must be > 0 (got 0)"});
}

TEST(ProgramYaml, NegativeDuration) {
  expect_error("program: {segments: [{shape: {type: circle, T: -0.5, tau: 0.1}}]}",
               {"program.segments[0].shape.T: must be > 0 (got -0.5)"});
}

TEST(ProgramYaml, TauAtHalfT) {
  expect_error("program: {segments: [{shape: {type: circle, T: 0.5, tau: 0.25}}]}",
               {"program.segments[0].shape.tau: must be in (0, T/2) = (0, 0.25) (got 0.25)"});
}

TEST(ProgramYaml, TauAboveHalfT) {
  expect_error("program: {segments: [{shape: {type: circle, T: 0.5, tau: 0.4}}]}",
               {"program.segments[0].shape.tau: must be in (0, T/2)"});
}

TEST(ProgramYaml, TauZero) {
  expect_error("program: {segments: [{shape: {type: circle, T: 0.5, tau: 0}}]}",
               {"program.segments[0].shape.tau: must be in (0, T/2)"});
}

TEST(ProgramYaml, TauMissingForRetiming) {
  expect_error("program: {segments: [{shape: {type: circle, T: 0.5}}]}",
               {"program.segments[0].shape.tau: missing (required by timing 'retimed')"});
}

TEST(ProgramYaml, TauNotNeededOnTheOriginalClock) {
  const Program p = load_yaml(
      "program: {segments: [{shape: {type: circle, T: 0.5, timing: original}}]}", home_context());
  EXPECT_EQ(p.segments()[0].motion.timing.kind, TimingKind::kOriginal);
}

TEST(ProgramYaml, TauAutoOnTheOriginalClock) {
  expect_error(
      "program: {segments: [{shape: {type: circle, T: 0.5, tau: auto, timing: original}}]}",
      {"program.segments[0].shape.tau: auto needs a blended timing law"});
}

TEST(ProgramYaml, TauNotANumber) {
  expect_error("program: {segments: [{shape: {type: circle, T: 0.5, tau: soon}}]}",
               {"program.segments[0].shape.tau: must be a number (got 'soon')"});
}

TEST(ProgramYaml, NegativePower) {
  expect_error(
      R"(
program:
  segments:
    - shape: {type: custom, T: 1, tau: 0.1, terms: {y: [{b: 0.01, beta: -2}]}}
)",
      {"program.segments[0].shape.terms.y[0].beta: must be an integer in [0, 16] (got -2)"});
}

TEST(ProgramYaml, PowerTooLarge) {
  expect_error(R"(
program:
  segments:
    - shape: {type: custom, T: 1, tau: 0.1, terms: {x: [{a: 0.01, alpha: 17}]}}
)",
               {"program.segments[0].shape.terms.x[0].alpha: must be an integer in [0, 16]"});
}

TEST(ProgramYaml, FractionalPower) {
  expect_error(R"(
program:
  segments:
    - shape: {type: custom, T: 1, tau: 0.1, terms: {x: [{a: 0.01, alpha: 1.5}]}}
)",
               {"program.segments[0].shape.terms.x[0].alpha: must be an integer"});
}

TEST(ProgramYaml, TooManyTerms) {
  std::string terms;
  for (std::size_t i = 0; i <= kMaxTerms; ++i) terms += std::string(i ? ", " : "") + "{a: 0.001}";
  expect_error(
      "program: {segments: [{shape: {type: custom, T: 1, tau: 0.1, terms: {x: [" + terms + "]}}}]}",
      {"program.segments[0].shape.terms.x: at most 8 terms (got 9)"});
}

TEST(ProgramYaml, PathLeavesTheWorkspace) {
  ProgramContext ctx = home_context();
  Workspace ws;
  ws.x = {-0.018, 0.018};  // the ellipse reaches +-20 mm
  ws.y = {0.2, 0.3};
  ws.theta = {-0.1, 0.1};
  ctx.workspace = ws;
  expect_error(R"(
program:
  segments:
    - ptp: {duration: 0.5}
    - shape: {type: circle, T: 0.5, tau: 0.1}
    - ptp: {duration: 0.5}
    - shape: {type: ellipse, T: 0.5, tau: 0.1}
)",
               {"program.segments[2] (ptp): path leaves the workspace", "x = 0.02",
                "outside [-0.018, 0.018] (trajectory.limits.workspace.x)",
                "program.segments[3] (shape ellipse): path leaves the workspace"},
               ctx);
  // The circle alone stays inside: no error.
  EXPECT_NO_THROW(
      load_yaml("program: {segments: [{ptp: {duration: 0.5}}, {shape: {type: circle, "
                "T: 0.5, tau: 0.1}}]}",
                ctx));
}

TEST(ProgramYaml, PtpWithoutTargetBeforeADwell) {
  expect_error("program: {segments: [{ptp: {duration: 0.5}}, {dwell: {duration: 1}}]}",
               {"program.segments[0].ptp.to: missing (may be omitted only when the next segment "
                "is a shape)"});
}

TEST(ProgramYaml, PtpTargetOfWrongLength) {
  expect_error("program: {segments: [{ptp: {to: [0.0, 0.25], duration: 0.5}}]}",
               {"program.segments[0].ptp.to: must be [x, y, theta] (got 2 numbers)"});
}

TEST(ProgramYaml, PtpTargetNotAPose) {
  expect_error("program: {segments: [{ptp: {to: away, duration: 0.5}}]}",
               {"program.segments[0].ptp.to: must be a list of numbers"});
}

TEST(ProgramYaml, PtpFromDoesNotMatchThePreviousEnd) {
  expect_error(R"(
program:
  segments:
    - dwell: {duration: 0.1}
    - ptp: {from: [0.01, 0.25, 0.0], to: home, duration: 0.5}
)",
               {"program.segments[1].ptp.from: (0.01, 0.25, 0) does not match the end of the "
                "previous segment (0, 0.25, 0)"});
}

TEST(ProgramYaml, ShapeNotJoinedToThePreviousSegment) {
  expect_error(R"(
program:
  segments:
    - ptp: {duration: 0.5}
    - shape: {type: circle, T: 0.5, tau: 0.1}
    - shape: {type: ellipse, T: 0.5, tau: 0.1}
)",
               {"program.segments[2]: the shape starts at (0.02, 0.25, 0) but the previous segment "
                "ends at (0.015, 0.25, 0): insert a ptp move"});
}

TEST(ProgramYaml, SegmentWithTwoKinds) {
  expect_error("program: {segments: [{dwell: {duration: 1}, ptp: {to: home, duration: 1}}]}",
               {"program.segments[0]: must have exactly one of ptp, shape, dwell"});
}

TEST(ProgramYaml, SegmentWithNoKind) {
  expect_error("program: {segments: [{wait: 1}]}",
               {"program.segments[0]: must have exactly one of ptp, shape, dwell"});
}

TEST(ProgramYaml, UnknownTimingLaw) {
  expect_error("program: {segments: [{shape: {type: circle, T: 0.5, tau: 0.1, timing: fast}}]}",
               {"program.segments[0].shape.timing: unknown timing law 'fast'"});
}

TEST(ProgramYaml, UnknownTimingOverride) {
  expect_error("program: {timing_override: fast, segments: [{dwell: {duration: 1}}]}",
               {"program.timing_override: unknown timing law 'fast'"});
}

TEST(ProgramYaml, NegativeDwell) {
  expect_error("program: {segments: [{dwell: {duration: -1}}]}",
               {"program.segments[0].dwell.duration: must be > 0 (got -1)"});
}

TEST(ProgramYaml, EmptySegments) {
  expect_error("program: {segments: []}", {"program.segments: must not be empty"});
}

TEST(ProgramYaml, MissingSegments) {
  expect_error("program: {timing_override: original}", {"program.segments: missing"});
}

TEST(ProgramYaml, MissingProgram) { expect_error("other: 1", {"program: missing"}); }

TEST(ProgramYaml, EqualLambdaBounds) {
  expect_error(
      "program: {segments: [{shape: {type: circle, T: 0.5, tau: 0.1, lambda0: 1, "
      "lambda_f: 1}}]}",
      {"program.segments[0].shape.lambda_f: must differ from lambda0"});
}

TEST(ProgramYaml, EveryProblemIsListedAtOnce) {
  try {
    load_yaml(R"(
program:
  segments:
    - shape: {type: circle, T: -1, tau: 0.1}
    - dwell: {duration: 0}
    - ptp: {to: home, duration: 1, speed: 2}
)",
              home_context());
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_GE(e.problems().size(), 3u);
  }
}

TEST(ProgramYaml, MissingFile) {
  EXPECT_THROW(load_program_file("/nonexistent/paper.yaml", home_context()), ConfigError);
}

// ---------------------------------------------------------------------------------------------
// Seeded randomised invariants (Ruckig style): many random shapes and timings

TEST(ProgramRandom, NoNanAndC2JoinsOverManyRandomPrograms) {
  std::mt19937 rng(20141103);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto amp = [&] { return 0.01 * (2 * u(rng) - 1); };
  for (int trial = 0; trial < 300; ++trial) {
    Program p(kHome);
    const int shapes = 1 + static_cast<int>(3 * u(rng));
    for (int k = 0; k < shapes; ++k) {
      TermList c[3];
      for (int axis = 0; axis < 3; ++axis) {
        const int n = static_cast<int>((kMaxTerms + 1) * u(rng));
        for (int i = 0; i < n; ++i)
          c[axis].push({amp(), static_cast<int>(6 * u(rng)), std::round(1 + 3 * u(rng)), amp(),
                        static_cast<int>(6 * u(rng)), std::round(1 + 3 * u(rng))});
      }
      const Shape s(kHome + Pose(amp(), amp(), 0), c[0], c[1], c[2]);
      TimingLaw law;
      law.kind = u(rng) < 0.5 ? TimingKind::kRetimed : TimingKind::kSmooth;
      law.T = 0.1 + 2 * u(rng);
      law.tau = (0.001 + 0.498 * u(rng)) * law.T;
      law.lambda0 = 2 * u(rng);
      law.lambda_f = law.lambda0 + (u(rng) < 0.2 ? -1 : 1) * (0.1 + 4 * std::numbers::pi * u(rng));
      p.add_ptp(s.position(law.lambda0), 0.05 + u(rng));
      p.add_shape(s, law);
      if (u(rng) < 0.5) p.add_dwell(0.01 + 0.2 * u(rng));
    }
    p.add_ptp(kHome, 0.05 + u(rng));
    ASSERT_GT(p.duration(), 0.0);

    CartesianSample c;
    PhaseSample ph;
    const double dt = p.duration() / 3000;
    for (double t = -0.1; t <= p.duration() + 0.1; t += dt) {
      p.sample(t, c, ph);
      ASSERT_TRUE(c.X.allFinite() && c.X_dot.allFinite() && c.X_dd.allFinite() &&
                  c.X_ddd.allFinite())
          << "trial " << trial << " t " << t;
      ASSERT_TRUE(std::isfinite(ph.lambda) && std::isfinite(ph.lambda_ddd));
    }
    for (const Segment& s : p.segments()) {
      // C2 joins: jumps below 1e-9, beyond what one ulp of t times the next derivative explains
      // (blends as short as 1e-4 s have jerks of 1e8 m/s^3).
      const Jumps j = jumps_at(p, s.t_start);
      EXPECT_LT(j.x, 1e-9) << "trial " << trial << " " << s.label;
      EXPECT_LT(j.v, 1e-9 + j.allowance_v) << "trial " << trial << " " << s.label;
      EXPECT_LT(j.a, 1e-9 + j.allowance_a) << "trial " << trial << " " << s.label;
    }
    p.sample(0.0, c, ph);
    EXPECT_LT(max_diff(c.X, kHome), 1e-15);
    p.sample(p.duration(), c, ph);
    EXPECT_LT(max_diff(c.X, kHome), 1e-12);
    EXPECT_LT(c.X_dot.norm() + c.X_dd.norm(), 1e-9);
  }
}

// Issue 14, defects 2 and 3: a huge duration is refused with its key (it used to overflow an
// int in the workspace check, and to reach a vector::reserve of the run's rows).
TEST(Program, HugeOrNonFiniteDurationsAreRefusedWithTheKey) {
  ProgramContext ctx = home_context();
  ctx.workspace = Workspace{{-1, 1}, {-1, 1}, {-1, 1}};
  for (const char* d : {"1e300", "1e12", "601"}) {
    try {
      load_yaml(std::string("program:\n  segments:\n    - dwell: {duration: ") + d + "}\n", ctx);
      ADD_FAILURE() << d << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(
          std::string(e.what()).find("program.segments[0].dwell.duration: must be at most 600"),
          std::string::npos)
          << e.what();
    }
  }
  for (const char* d : {".nan", ".inf", "-.inf"}) {
    EXPECT_THROW(load_yaml(std::string("program:\n  segments:\n    - shape: {type: circle, T: ") +
                               d + ", timing: original}\n",
                           ctx),
                 ConfigError)
        << d;
  }
  EXPECT_THROW(Program(kHome).add_dwell(1e300), ConfigError);
  EXPECT_THROW(Program(kHome).add_ptp(kHome, std::numeric_limits<double>::infinity()), ConfigError);
  // Many segments each within bounds, together over an hour: refused too.
  std::string many = "program:\n  segments:\n";
  for (int i = 0; i < 7; ++i) many += "    - dwell: {duration: 600}\n";
  try {
    load_yaml(many, ctx);
    ADD_FAILURE() << "a 4200 s program was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("more than 3600 s"), std::string::npos) << e.what();
  }
}

// Issue 14, defect 2: a program file's refusals name the file.
TEST(Program, FileProblemsNameTheFile) {
  const std::string path = ::testing::TempDir() + "/dualv_program_test_bad.yaml";
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs(
        "program:\n  segments:\n    - dwell: {duration: -1}\n    - dwell: {duration: 1, duration: "
        "2}\n",
        f);
    std::fclose(f);
  }
  try {
    load_program_file(path, home_context());
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    for (const auto& p : e.problems()) EXPECT_EQ(p.rfind(path, 0), 0u) << p;
    EXPECT_NE(std::string(e.what()).find("duplicate key"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dualv::trajectory
