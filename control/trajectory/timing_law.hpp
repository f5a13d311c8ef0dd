#pragma once
// Timing laws lambda(t) for a shape segment of duration T (Bennehar et al. 2014, eq. 9-16).
// The path X(lambda) is fixed by the shape (eq. 4); the clock decides how it is travelled:
//   x_dot = x'(lambda) lambda_dot, x_dd = x''(lambda) lambda_dot^2 + x'(lambda) lambda_dd (eq. 14)
//
// t is measured from the segment start (the paper's t - t0). Outside [0, T] the law holds its
// end value with zero derivatives (the robot is at rest before and after the shape); on the
// closed interval [0, T] the law itself applies, so the original clock moves at t = 0 and t = T.
// Sampling is noexcept and allocation-free; validation is set-up code (validate()).
#include <cstdint>
#include <string>
#include <string_view>

namespace dualv::trajectory {

enum class TimingKind : std::uint8_t {
  // Original affine clock, eq. 9: lambda = lambda0 + (lambda_f - lambda0) t / T. Velocity and
  // acceleration jump at t = 0 and t = T (eq. 7-8): kept for comparison only.
  kOriginal,
  // The paper's retiming, eq. 16: quartic blends of duration tau, linear in between; C2
  // (lambda_dot, lambda_dd continuous; jerk steps at 0, tau, T - tau, T).
  kRetimed,
  // Jerk-continuous variant (C3): lambda_dot ramps up along the quintic smooth step
  // s(u) = 10u^3 - 15u^4 + 6u^5 (u = t / tau), so lambda is a 6th-order polynomial in each
  // blend; lambda_dd and jerk are continuous and zero at both ends. Same flat-top speed as
  // eq. 16, peak lambda_dd = 1.875 V / tau (eq. 16: 1.5 V / tau).
  kSmooth,
};

const char* to_string(TimingKind kind) noexcept;
bool parse_timing_kind(std::string_view name, TimingKind& out) noexcept;  // original|retimed|smooth

struct PhaseSample {
  double lambda = 0.0;
  double lambda_dot = 0.0;  // [1/s]
  double lambda_dd = 0.0;   // [1/s^2]
  double lambda_ddd = 0.0;  // [1/s^3]
};

struct TimingLaw {
  TimingKind kind = TimingKind::kRetimed;
  double T = 1.0;        // segment duration [s] (eq. 9)
  double tau = 0.0;      // blend duration [s], 0 < tau < T/2 (eq. 16); unused by kOriginal
  double lambda0 = 0.0;  // lambda(0) (eq. 15)
  double lambda_f = 6.283185307179586;  // lambda(T)

  // Empty when usable, else the reason ("T must be > 0 (got ...)", "tau must be in (0, T/2)
  // ..."). Set-up code.
  std::string validate() const;

  // lambda(t) and its derivatives (eq. 9 or eq. 16 and their time derivatives). noexcept.
  PhaseSample sample(double t) const noexcept;

  // Flat-top phase speed of the blended laws, (lambda_f - lambda0) / (T - tau) (eq. 16), or the
  // affine clock's constant speed.
  double cruise_speed() const noexcept;
};

}  // namespace dualv::trajectory
