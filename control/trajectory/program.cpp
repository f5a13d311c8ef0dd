#include "control/trajectory/program.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "common/config_error.hpp"
#include "common/yaml_reader.hpp"
#include "control/trajectory/sample_count.hpp"

namespace dualv::trajectory {

namespace {

constexpr double kJoinTolerance = 1e-9;  // [m, rad]: consecutive segments must meet this closely

std::string pose_str(const Pose& p) {
  return fmt::format("({:.6g}, {:.6g}, {:.6g})", p[0], p[1], p[2]);
}

double pose_distance(const Pose& a, const Pose& b) { return (a - b).cwiseAbs().maxCoeff(); }

std::string validate_duration(double T) {
  if (!(std::isfinite(T) && T > 0.0)) return fmt::format("must be > 0 (got {})", T);
  if (T > kMaxSegmentDuration)
    return fmt::format("must be at most {} s (got {})", kMaxSegmentDuration, T);
  return {};
}

// A program that would grow past kMaxProgramDuration by `T` more seconds.
void check_program_length(const Program& p, double T, const std::string& label) {
  if (p.size() >= kMaxSegments)
    throw ConfigError({fmt::format("{}: a program has at most {} segments", label, kMaxSegments)});
  if (p.duration() + T > kMaxProgramDuration)
    throw ConfigError({fmt::format("{}: the program would last {} s, more than {} s", label,
                                   p.duration() + T, kMaxProgramDuration)});
}

}  // namespace

const char* to_string(SegmentKind kind) noexcept {
  switch (kind) {
    case SegmentKind::kPtp:
      return "ptp";
    case SegmentKind::kShape:
      return "shape";
    case SegmentKind::kDwell:
      return "dwell";
  }
  return "?";
}

// ---------------------------------------------------------------------------------------------
// Segment

double Segment::duration() const noexcept {
  switch (kind) {
    case SegmentKind::kPtp:
      return ptp.T;
    case SegmentKind::kShape:
      return motion.timing.T;
    case SegmentKind::kDwell:
      return dwell.T;
  }
  return 0.0;
}

Pose Segment::start_pose() const noexcept {
  switch (kind) {
    case SegmentKind::kPtp:
      return ptp.start;
    case SegmentKind::kShape:
      return motion.shape.position(motion.timing.lambda0);
    case SegmentKind::kDwell:
      return dwell.pose;
  }
  return Pose::Zero();
}

Pose Segment::end_pose() const noexcept {
  switch (kind) {
    case SegmentKind::kPtp:
      return ptp.end;
    case SegmentKind::kShape:
      return motion.shape.position(motion.timing.lambda_f);
    case SegmentKind::kDwell:
      return dwell.pose;
  }
  return Pose::Zero();
}

void Segment::sample(double t, CartesianSample& out, PhaseSample& phase) const noexcept {
  switch (kind) {
    case SegmentKind::kPtp:
      phase = PhaseSample{};
      ptp.sample(t, out);
      return;
    case SegmentKind::kDwell:
      phase = PhaseSample{};
      dwell.sample(t, out);
      return;
    case SegmentKind::kShape: {
      phase = motion.timing.sample(t);
      ShapePoint sp;
      motion.shape.evaluate(phase.lambda, sp);
      const double l1 = phase.lambda_dot, l2 = phase.lambda_dd, l3 = phase.lambda_ddd;
      // eq. 14 and its time derivative: X_dot = X' l1, X_dd = X'' l1^2 + X' l2,
      // X_ddd = X''' l1^3 + 3 X'' l1 l2 + X' l3.
      out.X = sp.p;
      out.X_dot = sp.d1 * l1;
      out.X_dd = sp.d2 * (l1 * l1) + sp.d1 * l2;
      out.X_ddd = sp.d3 * (l1 * l1 * l1) + sp.d2 * (3.0 * l1 * l2) + sp.d1 * l3;
      return;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Program

Pose Program::end_pose() const noexcept {
  return segments_.empty() ? start_ : segments_.back().end_pose();
}

void Program::retime() noexcept {
  Pose cur = start_;
  double t = 0.0;
  for (Segment& s : segments_) {
    s.t_start = t;
    if (s.kind == SegmentKind::kPtp && s.start_from_previous) s.ptp.start = cur;
    if (s.kind == SegmentKind::kDwell) s.dwell.pose = cur;
    cur = s.end_pose();
    t += s.duration();
  }
  duration_ = t;
}

Program& Program::add_ptp(const Pose& to, double duration, std::string label) {
  if (label.empty()) label = fmt::format("segment {} (ptp)", segments_.size());
  if (auto e = validate_duration(duration); !e.empty())
    throw ConfigError({fmt::format("{}: duration {}", label, e)});
  check_program_length(*this, duration, label);
  Segment s;
  s.kind = SegmentKind::kPtp;
  s.label = std::move(label);
  s.ptp = PtpMove{end_pose(), to, duration};
  segments_.push_back(std::move(s));
  retime();
  return *this;
}

Program& Program::add_shape(const Shape& shape, const TimingLaw& timing, std::string label) {
  if (label.empty()) label = fmt::format("segment {} (shape)", segments_.size());
  if (auto e = timing.validate(); !e.empty()) throw ConfigError({label + ": " + e});
  if (auto e = validate_duration(timing.T); !e.empty())
    throw ConfigError({fmt::format("{}: T {}", label, e)});
  check_program_length(*this, timing.T, label);
  const Pose start = shape.position(timing.lambda0);
  const Pose prev = end_pose();
  if (pose_distance(start, prev) > kJoinTolerance)
    throw ConfigError(
        {fmt::format("{}: starts at {} but the previous segment ends at {}: join "
                     "them with a ptp move",
                     label, pose_str(start), pose_str(prev))});
  Segment s;
  s.kind = SegmentKind::kShape;
  s.label = std::move(label);
  s.motion = ShapeMotion{shape, timing};
  segments_.push_back(std::move(s));
  retime();
  return *this;
}

Program& Program::add_dwell(double duration, std::string label) {
  if (label.empty()) label = fmt::format("segment {} (dwell)", segments_.size());
  if (auto e = validate_duration(duration); !e.empty())
    throw ConfigError({fmt::format("{}: duration {}", label, e)});
  check_program_length(*this, duration, label);
  Segment s;
  s.kind = SegmentKind::kDwell;
  s.label = std::move(label);
  s.dwell = Dwell{end_pose(), duration};
  segments_.push_back(std::move(s));
  retime();
  return *this;
}

void Program::set_timing(std::size_t segment, const TimingLaw& timing) {
  if (segment >= segments_.size() || segments_[segment].kind != SegmentKind::kShape)
    throw ConfigError({fmt::format("segment {}: not a shape segment", segment)});
  Segment& s = segments_[segment];
  if (auto e = timing.validate(); !e.empty()) throw ConfigError({s.label + ": " + e});
  s.motion.timing = timing;
  retime();
}

std::size_t Program::segment_at(double t) const noexcept {
  if (segments_.empty()) return 0;
  auto it = std::upper_bound(segments_.begin(), segments_.end(), t,
                             [](double v, const Segment& s) { return v < s.t_start; });
  if (it == segments_.begin()) return 0;
  return static_cast<std::size_t>(std::distance(segments_.begin(), it)) - 1;
}

std::size_t Program::sample(double t, CartesianSample& out, PhaseSample& phase) const noexcept {
  if (segments_.empty()) {
    out = CartesianSample{};
    out.X = start_;
    phase = PhaseSample{};
    return 0;
  }
  if (std::isnan(t)) t = -1.0;  // at rest on the start pose
  const std::size_t k = segment_at(t);
  const Segment& s = segments_[k];
  s.sample(t - s.t_start, out, phase);
  return k;
}

// ---------------------------------------------------------------------------------------------
// Editing whole programs

Program with_timing(const Program& program, TimingKind kind, double default_tau_fraction) {
  if (!(default_tau_fraction > 0.0 && default_tau_fraction < 0.5))
    throw ConfigError(
        {fmt::format("default_tau_fraction: must be in (0, 0.5) (got {})", default_tau_fraction)});
  Program out = program;
  for (Segment& s : out.mutable_segments()) {
    if (s.kind != SegmentKind::kShape) continue;
    TimingLaw& law = s.motion.timing;
    law.kind = kind;
    if (kind != TimingKind::kOriginal && !(law.tau > 0.0 && law.tau < 0.5 * law.T))
      law.tau = default_tau_fraction * law.T;
  }
  out.retime();
  return out;
}

Program rebase(const Program& program, const Pose& actual, const RebaseOptions& o) {
  Program out = program;
  auto& segs = out.mutable_segments();
  if (segs.empty() ||
      (segs.front().kind == SegmentKind::kPtp && segs.front().start_from_previous)) {
    out.set_start_pose(actual);
    if (!segs.empty()) {
      PtpMove& m = segs.front().ptp;
      m.T = std::max(m.T, ptp_min_duration(actual, m.end, o.max_speed, o.max_acceleration,
                                           o.max_angular_speed, o.max_angular_acceleration));
    }
    out.retime();
    return out;
  }
  const Pose first = segs.front().start_pose();
  if (pose_distance(first, actual) <= o.tolerance) return out;
  Segment s;
  s.kind = SegmentKind::kPtp;
  s.label = "rebase move (actual pose to the program's first pose)";
  s.start_from_previous = true;
  const double T = ptp_min_duration(actual, first, o.max_speed, o.max_acceleration,
                                    o.max_angular_speed, o.max_angular_acceleration);
  s.ptp = PtpMove{actual, first, std::max(T, 1e-3)};
  // The old first segment keeps its start: a PtP `from`, the shape's own start, or (a dwell
  // follows the previous end) the end of the joining move.
  segs.insert(segs.begin(), std::move(s));
  out.set_start_pose(actual);
  out.retime();
  return out;
}

// ---------------------------------------------------------------------------------------------
// Loading

namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

enum class PtpTarget { kPose, kHome, kNextStart };

struct RawSegment {
  SegmentKind kind = SegmentKind::kDwell;
  std::string key;  // "program.segments[3]"
  // ptp
  PtpTarget target = PtpTarget::kNextStart;
  Pose to = Pose::Zero();
  std::optional<Pose> from;
  double duration = 0.0;
  // shape
  ShapeMotion motion;
  std::string shape_name;
  bool auto_tau = false;
};

std::optional<Pose> read_pose(YamlReader& r, const std::string& key) {
  if (!r.has(key)) return std::nullopt;  // optional everywhere
  const std::vector<double> v = r.numbers(key);
  if (v.size() != 3) {
    r.problem(fmt::format("{}: must be [x, y, theta] (got {} numbers)", r.key_path(key), v.size()));
    return std::nullopt;
  }
  return Pose(v[0], v[1], v[2]);
}

int read_power(YamlReader& r, const std::string& key) {
  const bool present = r.has(key);
  const int p = r.integer(key, 1);
  if (present && (p < 0 || p > kMaxPower)) {
    r.problem(
        fmt::format("{}: must be an integer in [0, {}] (got {})", r.key_path(key), kMaxPower, p));
    return 1;
  }
  return p;
}

TermList read_terms(YamlReader& terms, const std::string& coord) {
  TermList out;
  std::vector<YamlReader> items = terms.children(coord, false);
  if (items.size() > kMaxTerms)
    terms.problem(fmt::format("{}: at most {} terms (got {})", terms.key_path(coord), kMaxTerms,
                              items.size()));
  for (YamlReader& it : items) {
    ShapeTerm t;
    t.a = it.number("a", 0.0);
    t.alpha = read_power(it, "alpha");
    t.n1 = it.number("n1", 1.0);
    t.b = it.number("b", 0.0);
    t.beta = read_power(it, "beta");
    t.n2 = it.number("n2", 1.0);
    it.reject_unknown_keys();
    out.push(t);
  }
  return out;
}

void read_shape(YamlReader& r, const YAML::Node& raw, RawSegment& seg, const ProgramContext& ctx) {
  const std::string type = r.string("type");
  const Pose centre = read_pose(r, "centre").value_or(ctx.home);
  BuiltinShape builtin{};
  if (type == "custom") {
    YamlReader terms = r.child("terms");
    const TermList x = read_terms(terms, "x");
    const TermList y = read_terms(terms, "y");
    const TermList th = read_terms(terms, "theta");
    terms.reject_unknown_keys();
    seg.motion.shape = Shape(centre, x, y, th);
  } else if (parse_builtin_shape(type, builtin)) {
    const double scale = r.positive("scale", 1.0);
    seg.motion.shape = make_builtin_shape(builtin, centre, scale);
  } else if (!type.empty()) {
    r.problem(
        fmt::format("{}: unknown shape '{}' (expected circle, ellipse, tear, deltoid or "
                    "custom)",
                    r.key_path("type"), type));
  }
  seg.shape_name = type;

  TimingLaw& law = seg.motion.timing;
  law.T = r.positive("T");
  r.require(!(law.T > kMaxSegmentDuration), "T",
            fmt::format("must be at most {} s (program.hpp)", kMaxSegmentDuration), law.T);
  const std::string timing = r.string("timing", "retimed");
  if (!parse_timing_kind(timing, law.kind))
    r.problem(fmt::format("{}: unknown timing law '{}' (expected original, retimed or smooth)",
                          r.key_path("timing"), timing));
  const bool has_tau = r.has("tau");
  const YAML::Node tau = raw.IsMap() ? raw["tau"] : YAML::Node();
  if (tau.IsDefined() && tau.IsScalar() && tau.Scalar() == "auto") {
    r.string("tau");
    seg.auto_tau = true;
    law.tau = 0.2 * law.T;  // placeholder until resolve_auto_blends()
    if (law.kind == TimingKind::kOriginal)
      r.problem(fmt::format("{}: auto needs a blended timing law (retimed or smooth)",
                            r.key_path("tau")));
  } else if (has_tau) {
    law.tau = r.number("tau", 0.0);
    if (!(law.tau > 0.0 && law.tau < 0.5 * law.T))
      r.problem(fmt::format("{}: must be in (0, T/2) = (0, {}) (got {})", r.key_path("tau"),
                            0.5 * law.T, law.tau));
  } else if (law.kind != TimingKind::kOriginal) {
    r.problem(fmt::format("{}: missing (required by timing '{}')", r.key_path("tau"), timing));
  }
  law.lambda0 = r.number("lambda0", 0.0);
  law.lambda_f = r.number("lambda_f", kTwoPi);
  if (r.has("lambda_f") || r.has("lambda0"))
    r.require(law.lambda_f != law.lambda0, "lambda_f", "must differ from lambda0", law.lambda_f);
}

double read_duration(YamlReader& r) {
  const double d = r.positive("duration");
  r.require(!(d > kMaxSegmentDuration), "duration",
            fmt::format("must be at most {} s (program.hpp)", kMaxSegmentDuration), d);
  return d;
}

void read_segment(YamlReader& item, const YAML::Node& raw, RawSegment& seg,
                  const ProgramContext& ctx) {
  const bool p = item.has("ptp"), s = item.has("shape"), d = item.has("dwell");
  if (int(p) + int(s) + int(d) != 1) {
    item.problem(fmt::format("{}: must have exactly one of ptp, shape, dwell", item.path()));
    return;
  }
  if (p) {
    seg.kind = SegmentKind::kPtp;
    YamlReader r = item.child("ptp");
    const YAML::Node to = raw["ptp"].IsMap() ? raw["ptp"]["to"] : YAML::Node();
    if (to.IsDefined() && to.IsScalar() && to.Scalar() == "home") {
      r.string("to");
      seg.target = PtpTarget::kHome;
    } else if (auto pose = read_pose(r, "to")) {
      seg.target = PtpTarget::kPose;
      seg.to = *pose;
    } else if (!to.IsDefined() || to.IsNull()) {
      seg.target = PtpTarget::kNextStart;
    }
    seg.from = read_pose(r, "from");
    seg.duration = read_duration(r);
    r.reject_unknown_keys();
  } else if (s) {
    seg.kind = SegmentKind::kShape;
    YamlReader r = item.child("shape");
    read_shape(r, raw["shape"], seg, ctx);
    r.reject_unknown_keys();
  } else {
    seg.kind = SegmentKind::kDwell;
    YamlReader r = item.child("dwell");
    seg.duration = read_duration(r);
    r.reject_unknown_keys();
  }
}

// First sample of a segment outside the box, as a message naming the limit key.
std::optional<std::string> workspace_exit(const Segment& s, const Workspace& ws, double period) {
  const double T = s.duration();
  const auto intervals =
      sample_intervals(T, period, 1, static_cast<int>(kMaxSegmentDuration / 1e-6));
  if (!intervals)
    return fmt::format("{}: duration {} s cannot be sampled every {} s", s.label, T, period);
  const int n = *intervals;
  CartesianSample c;
  PhaseSample ph;
  for (int i = 0; i <= n; ++i) {
    const double t = T * i / n;
    s.sample(t, c, ph);
    const Interval* box[3] = {&ws.x, &ws.y, &ws.theta};
    const char* names[3] = {"x", "y", "theta"};
    const char* units[3] = {"m", "m", "rad"};
    for (int k = 0; k < 3; ++k) {
      if (!box[k]->contains(c.X[k]))
        return fmt::format(
            "{}: path leaves the workspace at t = {:.4f} s into the segment: "
            "{} = {:.6g} {} outside [{}, {}] (trajectory.limits.workspace.{})",
            s.label, t, names[k], c.X[k], units[k], box[k]->lo, box[k]->hi, names[k]);
    }
  }
  return std::nullopt;
}

}  // namespace

Program load_program(const YAML::Node& program_node_in, const ProgramContext& ctx) {
  // An absent key of a const node is an invalid node that throws on use: read it as null.
  const YAML::Node program_node = program_node_in.IsDefined() ? program_node_in : YAML::Node();
  ConfigProblems problems;
  YamlReader root(program_node, "program", problems.sink());
  if (!root.valid()) root.problem("program: missing");

  std::optional<TimingKind> override_kind;
  if (root.has("timing_override")) {
    const std::string name = root.string("timing_override");
    TimingKind k{};
    if (parse_timing_kind(name, k))
      override_kind = k;
    else
      root.problem(
          fmt::format("program.timing_override: unknown timing law '{}' (expected "
                      "original, retimed or smooth)",
                      name));
  }
  std::vector<YamlReader> items = root.children("segments");
  const YAML::Node raw_items = root.has("segments") ? program_node["segments"] : YAML::Node();
  if (root.valid() && raw_items.IsSequence() && items.empty())
    root.problem("program.segments: must not be empty");
  if (items.size() > kMaxSegments) {
    root.problem(
        fmt::format("program.segments: at most {} segments (got {})", kMaxSegments, items.size()));
    problems.finish();
  }
  root.reject_unknown_keys();

  std::vector<RawSegment> raw(items.size());
  for (std::size_t i = 0; i < items.size(); ++i) {
    raw[i].key = items[i].path();
    read_segment(items[i], raw_items[i], raw[i], ctx);
    items[i].reject_unknown_keys();
  }
  problems.finish();  // poses cannot be chained through broken segments

  // Chain poses: every segment starts where the previous one ends.
  Program program(ctx.start);
  auto& segs = program.mutable_segments();
  Pose cur = ctx.start;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const RawSegment& r = raw[i];
    Segment s;
    s.kind = r.kind;
    if (r.kind == SegmentKind::kShape) {
      s.label = fmt::format("{} (shape {})", r.key, r.shape_name);
      s.motion = r.motion;
      s.auto_tau = r.auto_tau;
      const Pose start = s.start_pose();
      if (i == 0) {
        program.set_start_pose(start);  // rebase() joins the robot to it
      } else if (pose_distance(start, cur) > kJoinTolerance) {
        problems.sink()->push_back(fmt::format(
            "{}: the shape starts at {} but the previous segment ends at {}: insert a ptp "
            "move before it",
            r.key, pose_str(start), pose_str(cur)));
      }
    } else if (r.kind == SegmentKind::kPtp) {
      s.label = fmt::format("{} (ptp)", r.key);
      Pose start = cur;
      if (r.from) {
        s.start_from_previous = false;
        if (i == 0) {
          program.set_start_pose(*r.from);
        } else if (pose_distance(*r.from, cur) > kJoinTolerance) {
          problems.sink()->push_back(
              fmt::format("{}.ptp.from: {} does not match the end of the previous segment {}",
                          r.key, pose_str(*r.from), pose_str(cur)));
        }
        start = *r.from;
      }
      Pose to = r.to;
      if (r.target == PtpTarget::kHome) to = ctx.home;
      if (r.target == PtpTarget::kNextStart) {
        if (i + 1 < raw.size() && raw[i + 1].kind == SegmentKind::kShape) {
          to = raw[i + 1].motion.shape.position(raw[i + 1].motion.timing.lambda0);
        } else {
          problems.sink()->push_back(fmt::format(
              "{}.ptp.to: missing (may be omitted only when the next segment is a shape)", r.key));
        }
      }
      s.ptp = PtpMove{start, to, r.duration};
    } else {
      s.label = fmt::format("{} (dwell)", r.key);
      s.dwell = Dwell{cur, r.duration};
    }
    segs.push_back(std::move(s));
    program.retime();
    cur = program.end_pose();
  }
  if (program.duration() > kMaxProgramDuration)
    problems.sink()->push_back(
        fmt::format("program.segments: the program lasts {} s, more than {} s (program.hpp)",
                    program.duration(), kMaxProgramDuration));
  problems.finish();

  if (override_kind) program = with_timing(program, *override_kind);

  if (ctx.workspace) {
    for (const Segment& s : program.segments())
      if (auto msg = workspace_exit(s, *ctx.workspace, ctx.workspace_check_period))
        problems.sink()->push_back(*msg);
  }
  problems.finish();
  return program;
}

Program load_program_file(const std::string& path, const ProgramContext& context) {
  Program program;
  prefix_problems(path, [&] {
    const YAML::Node doc = YamlReader::load_file(path);
    for (const auto& kv : doc)
      if (kv.first.Scalar() != "program")
        throw ConfigError({fmt::format("{}: unknown section (a program file holds `program:` only)",
                                       kv.first.Scalar())});
    program = load_program(doc["program"], context);
  });
  return program;
}

}  // namespace dualv::trajectory
