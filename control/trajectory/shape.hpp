#pragma once
// Closed shapes of the paper's general form (Bennehar et al. 2014, eq. 4), written in a phase
// lambda instead of time (eq. 12-13): every coordinate c of the plate pose X = (x, y, theta) is
//
//   c(lambda) = c_0 + sum_i  a_i cos^{alpha_i}(n1_i lambda) + b_i sin^{beta_i}(n2_i lambda)
//
// about a centre pose c_0. With lambda = 2 pi t / T this is eq. 4 itself (the original clock,
// eq. 9); the timing laws in timing_law.hpp change lambda(t) without changing the path.
//
// Storage is fixed-capacity (kMaxTerms per coordinate) and evaluation is noexcept and allocates
// nothing: shapes are sampled on the real-time path.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <string_view>

namespace dualv::trajectory {

using Pose = Eigen::Vector3d;   // (x [m], y [m], theta [rad]), world frame
using Twist = Eigen::Vector3d;  // its time (or lambda) derivatives

inline constexpr std::size_t kMaxTerms = 8;  // eq. 4 terms per coordinate
inline constexpr int kMaxPower = 16;         // alpha, beta in [0, kMaxPower]

// One term of eq. 4: a cos^alpha(n1 lambda) + b sin^beta(n2 lambda). Powers are non-negative
// integers (a real power of a negative cosine is undefined); frequencies n1, n2 are real (a
// half-integer frequency with an even power still closes on [0, 2 pi]).
struct ShapeTerm {
  double a = 0.0;  // [m] for x, y; [rad] for theta
  int alpha = 1;
  double n1 = 1.0;
  double b = 0.0;
  int beta = 1;
  double n2 = 1.0;
};

// A coordinate's terms, fixed capacity.
struct TermList {
  std::array<ShapeTerm, kMaxTerms> terms{};
  std::size_t size = 0;
  // Appends a term; false when full (set-up code turns that into a ConfigError).
  bool push(const ShapeTerm& t) noexcept;
};

// Pose and its first three derivatives with respect to lambda.
struct ShapePoint {
  Pose p = Pose::Zero();     // X(lambda)
  Twist d1 = Twist::Zero();  // dX/dlambda
  Twist d2 = Twist::Zero();  // d2X/dlambda2
  Twist d3 = Twist::Zero();  // d3X/dlambda3
};

class Shape {
 public:
  Shape() = default;
  Shape(const Pose& centre, const TermList& x, const TermList& y, const TermList& theta) noexcept;

  // X(lambda) and its analytic derivatives (eq. 4 and its lambda derivatives). noexcept,
  // allocation-free.
  void evaluate(double lambda, ShapePoint& out) const noexcept;
  Pose position(double lambda) const noexcept;

  const Pose& centre() const noexcept { return centre_; }
  void set_centre(const Pose& c) noexcept { centre_ = c; }
  const TermList& terms(int coordinate) const noexcept { return coords_[coordinate]; }

 private:
  Pose centre_ = Pose::Zero();
  std::array<TermList, 3> coords_{};  // x, y, theta
};

// Built-in shapes, sized like the paper's experiment (section V: the reference spans about
// +-20 mm in x and +-15 mm in y), each in eq. 4 form about `centre`, closed on lambda in
// [0, 2 pi] (X(0) = X(2 pi)); `scale` multiplies every amplitude. theta stays at the centre.
//   circle:   x = r cos l, y = r sin l,                               r = 15 mm
//   ellipse:  x = a cos l, y = b sin l,                               a = 20 mm, b = 15 mm
//   tear:     x = a cos l, y = b sin l sin^2(l/2) = (b/2) sin l - (b/4) sin 2l,
//             a = 20 mm, b = 23.09 mm (peak |y| = 0.6495 b = 15 mm); the point (a cusp of
//             order 3/2) at l = 0, the round end at l = pi
//   deltoid:  x = s (2 cos l + cos 2l), y = s (2 sin l - sin 2l),     s = 5.7735 mm
//             (|y| <= 15 mm, x in [-8.7, 17.3] mm; cusps at l = 0, 2pi/3, 4pi/3)
enum class BuiltinShape { kCircle, kEllipse, kTear, kDeltoid };

Shape make_builtin_shape(BuiltinShape kind, const Pose& centre, double scale = 1.0) noexcept;
// "circle", "ellipse", "tear", "deltoid"; false for an unknown name.
bool parse_builtin_shape(std::string_view name, BuiltinShape& out) noexcept;
const char* to_string(BuiltinShape kind) noexcept;

}  // namespace dualv::trajectory
