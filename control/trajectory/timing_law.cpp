#include "control/trajectory/timing_law.hpp"

#include <fmt/format.h>

#include <cmath>

namespace dualv::trajectory {

const char* to_string(TimingKind kind) noexcept {
  switch (kind) {
    case TimingKind::kOriginal:
      return "original";
    case TimingKind::kRetimed:
      return "retimed";
    case TimingKind::kSmooth:
      return "smooth";
  }
  return "?";
}

bool parse_timing_kind(std::string_view name, TimingKind& out) noexcept {
  if (name == "original")
    out = TimingKind::kOriginal;
  else if (name == "retimed")
    out = TimingKind::kRetimed;
  else if (name == "smooth")
    out = TimingKind::kSmooth;
  else
    return false;
  return true;
}

std::string TimingLaw::validate() const {
  if (!(std::isfinite(T) && T > 0.0)) return fmt::format("T must be > 0 (got {})", T);
  if (!(std::isfinite(lambda0) && std::isfinite(lambda_f)))
    return "lambda0 and lambda_f must be finite";
  if (kind != TimingKind::kOriginal && !(tau > 0.0 && tau < 0.5 * T))
    return fmt::format("tau must be in (0, T/2) = (0, {}) (got {})", 0.5 * T, tau);
  return {};
}

double TimingLaw::cruise_speed() const noexcept {
  const double d = lambda_f - lambda0;
  return kind == TimingKind::kOriginal ? d / T : d / (T - tau);
}

namespace {

// Start blend of eq. 16 (0 <= t <= tau), relative to lambda0, with k = D / (2 tau^3 (T - tau)):
//   lambda = k (-t^4 + 2 tau t^3)
PhaseSample quartic_blend(double t, double k, double tau) noexcept {
  PhaseSample s;
  s.lambda = k * (-t * t * t * t + 2.0 * tau * t * t * t);
  s.lambda_dot = k * (-4.0 * t * t * t + 6.0 * tau * t * t);
  s.lambda_dd = k * (-12.0 * t * t + 12.0 * tau * t);
  s.lambda_ddd = k * (-24.0 * t + 12.0 * tau);
  return s;
}

// C3 start blend: lambda_dot = V s(u), u = t / tau, s = 10u^3 - 15u^4 + 6u^5, so
//   lambda = V tau (2.5 u^4 - 3 u^5 + u^6)  (= V tau / 2 at u = 1, as in eq. 16).
PhaseSample smooth_blend(double t, double V, double tau) noexcept {
  const double u = t / tau;
  const double u2 = u * u, u3 = u2 * u, u4 = u3 * u;
  PhaseSample s;
  s.lambda = V * tau * (2.5 * u4 - 3.0 * u4 * u + u4 * u2);
  s.lambda_dot = V * (10.0 * u3 - 15.0 * u4 + 6.0 * u4 * u);
  s.lambda_dd = V / tau * (30.0 * u2 - 60.0 * u3 + 30.0 * u4);
  s.lambda_ddd = V / (tau * tau) * (60.0 * u - 180.0 * u2 + 120.0 * u3);
  return s;
}

PhaseSample blend(TimingKind kind, double t, double D, double T, double tau) noexcept {
  if (kind == TimingKind::kSmooth) return smooth_blend(t, D / (T - tau), tau);
  return quartic_blend(t, D / (2.0 * tau * tau * tau * (T - tau)), tau);
}

}  // namespace

PhaseSample TimingLaw::sample(double t) const noexcept {
  const double D = lambda_f - lambda0;
  PhaseSample s;
  if (!(t >= 0.0)) {  // before the start (and NaN): at rest at lambda0
    s.lambda = lambda0;
    return s;
  }
  if (t > T) {  // after the end: at rest at lambda_f
    s.lambda = lambda_f;
    return s;
  }
  if (kind == TimingKind::kOriginal) {  // eq. 9 on the closed interval [0, T]
    s.lambda = lambda0 + D * t / T;
    s.lambda_dot = D / T;
    return s;
  }
  if (t <= tau) {  // eq. 16, first line
    s = blend(kind, t, D, T, tau);
    s.lambda += lambda0;
    return s;
  }
  if (t < T - tau) {  // eq. 16, second line: lambda = D / (T - tau) (t - tau/2) + lambda0
    s.lambda = D / (T - tau) * (t - 0.5 * tau) + lambda0;
    s.lambda_dot = D / (T - tau);
    return s;
  }
  // eq. 16, third line: the start blend mirrored in time about T/2 (point symmetry of
  // lambda about (T/2, (lambda0 + lambda_f)/2)): lambda(t) = lambda_f - b(T - t).
  const PhaseSample m = blend(kind, T - t, D, T, tau);
  s.lambda = lambda_f - m.lambda;
  s.lambda_dot = m.lambda_dot;
  s.lambda_dd = -m.lambda_dd;
  s.lambda_ddd = m.lambda_ddd;
  return s;
}

}  // namespace dualv::trajectory
