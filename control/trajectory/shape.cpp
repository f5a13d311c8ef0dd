#include "control/trajectory/shape.hpp"

#include <cmath>
#include <numbers>

namespace dualv::trajectory {

namespace {

// x^k for an integer k >= 0; 0 for k < 0 (callers multiply such terms by a zero factor).
inline double ipow(double x, int k) noexcept {
  if (k < 0) return 0.0;
  double r = 1.0;
  double b = x;
  while (k > 0) {
    if (k & 1) r *= b;
    b *= b;
    k >>= 1;
  }
  return r;
}

// f = coef * cos^p(n l) and its l-derivatives (eq. 4, differentiated as in eq. 13-14):
//   f'   = -n p C^{p-1} S
//   f''  =  n^2 p [(p-1) C^{p-2} S^2 - C^p]
//   f''' =  n^3 p [-(p-1)(p-2) C^{p-3} S^3 + (3p-2) C^{p-1} S]
// with C = cos(n l), S = sin(n l). Powers below zero only appear with a zero factor.
inline void add_cos_power(double coef, int p, double n, double l, double out[4]) noexcept {
  if (coef == 0.0) return;
  if (p == 0) {
    out[0] += coef;
    return;
  }
  const double C = std::cos(n * l);
  const double S = std::sin(n * l);
  const double Cp1 = ipow(C, p - 1);  // C^{p-1}
  const double Cp = Cp1 * C;
  const double Cp2 = p >= 2 ? ipow(C, p - 2) : 0.0;
  const double Cp3 = p >= 3 ? ipow(C, p - 3) : 0.0;
  const double dp = p;
  out[0] += coef * Cp;
  out[1] += coef * (-n * dp * Cp1 * S);
  out[2] += coef * (n * n * dp * ((dp - 1.0) * Cp2 * S * S - Cp));
  out[3] += coef * (n * n * n * dp *
                    (-(dp - 1.0) * (dp - 2.0) * Cp3 * S * S * S + (3.0 * dp - 2.0) * Cp1 * S));
}

// g = coef * sin^p(n l):
//   g'   =  n p S^{p-1} C
//   g''  =  n^2 p [(p-1) S^{p-2} C^2 - S^p]
//   g''' =  n^3 p [(p-1)(p-2) S^{p-3} C^3 - (3p-2) S^{p-1} C]
inline void add_sin_power(double coef, int p, double n, double l, double out[4]) noexcept {
  if (coef == 0.0) return;
  if (p == 0) {
    out[0] += coef;
    return;
  }
  const double C = std::cos(n * l);
  const double S = std::sin(n * l);
  const double Sp1 = ipow(S, p - 1);
  const double Sp = Sp1 * S;
  const double Sp2 = p >= 2 ? ipow(S, p - 2) : 0.0;
  const double Sp3 = p >= 3 ? ipow(S, p - 3) : 0.0;
  const double dp = p;
  out[0] += coef * Sp;
  out[1] += coef * (n * dp * Sp1 * C);
  out[2] += coef * (n * n * dp * ((dp - 1.0) * Sp2 * C * C - Sp));
  out[3] += coef * (n * n * n * dp *
                    ((dp - 1.0) * (dp - 2.0) * Sp3 * C * C * C - (3.0 * dp - 2.0) * Sp1 * C));
}

TermList terms(std::initializer_list<ShapeTerm> list) noexcept {
  TermList out;
  for (const auto& t : list) out.push(t);
  return out;
}

}  // namespace

bool TermList::push(const ShapeTerm& t) noexcept {
  if (size >= kMaxTerms) return false;
  terms[size++] = t;
  return true;
}

Shape::Shape(const Pose& centre, const TermList& x, const TermList& y,
             const TermList& theta) noexcept
    : centre_(centre), coords_{x, y, theta} {}

void Shape::evaluate(double lambda, ShapePoint& out) const noexcept {
  for (int c = 0; c < 3; ++c) {
    double acc[4] = {centre_[c], 0.0, 0.0, 0.0};
    const TermList& list = coords_[c];
    for (std::size_t i = 0; i < list.size; ++i) {
      const ShapeTerm& t = list.terms[i];
      add_cos_power(t.a, t.alpha, t.n1, lambda, acc);
      add_sin_power(t.b, t.beta, t.n2, lambda, acc);
    }
    out.p[c] = acc[0];
    out.d1[c] = acc[1];
    out.d2[c] = acc[2];
    out.d3[c] = acc[3];
  }
}

Pose Shape::position(double lambda) const noexcept {
  ShapePoint pt;
  evaluate(lambda, pt);
  return pt.p;
}

Shape make_builtin_shape(BuiltinShape kind, const Pose& centre, double scale) noexcept {
  const TermList none;
  switch (kind) {
    case BuiltinShape::kCircle: {
      const double r = 0.015 * scale;
      return Shape(centre, terms({{r, 1, 1.0, 0.0, 1, 1.0}}), terms({{0.0, 1, 1.0, r, 1, 1.0}}),
                   none);
    }
    case BuiltinShape::kEllipse: {
      const double a = 0.020 * scale, b = 0.015 * scale;
      return Shape(centre, terms({{a, 1, 1.0, 0.0, 1, 1.0}}), terms({{0.0, 1, 1.0, b, 1, 1.0}}),
                   none);
    }
    case BuiltinShape::kTear: {
      // y = b sin l sin^2(l/2) = (b/2) sin l - (b/4) sin 2l; max |y| = 0.649519 b at l = 2pi/3.
      const double a = 0.020 * scale;
      const double b = 0.015 * scale / (std::sqrt(3.0) / 2.0 * 0.75);
      return Shape(centre, terms({{a, 1, 1.0, 0.0, 1, 1.0}}),
                   terms({{0.0, 1, 1.0, b / 2.0, 1, 1.0}, {0.0, 1, 1.0, -b / 4.0, 1, 2.0}}), none);
    }
    case BuiltinShape::kDeltoid: {
      // max |2 sin l - sin 2l| = 3 sqrt(3) / 2 at l = 2pi/3.
      const double s = 0.015 * scale / (1.5 * std::sqrt(3.0));
      return Shape(centre, terms({{2.0 * s, 1, 1.0, 0.0, 1, 1.0}, {s, 1, 2.0, 0.0, 1, 1.0}}),
                   terms({{0.0, 1, 1.0, 2.0 * s, 1, 1.0}, {0.0, 1, 1.0, -s, 1, 2.0}}), none);
    }
  }
  return Shape(centre, none, none, none);
}

bool parse_builtin_shape(std::string_view name, BuiltinShape& out) noexcept {
  if (name == "circle")
    out = BuiltinShape::kCircle;
  else if (name == "ellipse")
    out = BuiltinShape::kEllipse;
  else if (name == "tear")
    out = BuiltinShape::kTear;
  else if (name == "deltoid")
    out = BuiltinShape::kDeltoid;
  else
    return false;
  return true;
}

const char* to_string(BuiltinShape kind) noexcept {
  switch (kind) {
    case BuiltinShape::kCircle:
      return "circle";
    case BuiltinShape::kEllipse:
      return "ellipse";
    case BuiltinShape::kTear:
      return "tear";
    case BuiltinShape::kDeltoid:
      return "deltoid";
  }
  return "?";
}

}  // namespace dualv::trajectory
