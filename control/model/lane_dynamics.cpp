#include "control/model/lane_dynamics.hpp"

#include <cmath>
#include <cstring>
#if defined(__x86_64__) && defined(__clang__) && __clang_major__ < 16
#include <cpuid.h>
#endif
#include <stdexcept>
#include <string>

#include "control/model/dynamics.hpp"
#include "control/model/kinematics.hpp"

// Lane vectors pass between functions only inside this file, all inlined into
// update_avx2 / update_baseline (always_inline): no call ever crosses the AVX ABI GCC warns about.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace dualv::model {

namespace {

// W doubles side by side (GCC vector extension: element-wise arithmetic, lane access by
// index). The attribute does not take a template argument, hence one type per width.
template <int W>
struct LanesOf;
template <>
struct LanesOf<2> {
  typedef double type __attribute__((vector_size(16)));
};
template <>
struct LanesOf<4> {
  typedef double type __attribute__((vector_size(32)));
};
template <int W>
using Lanes = typename LanesOf<W>::type;

template <int W>
[[gnu::always_inline]] inline Lanes<W> load(const double* p) noexcept {
  Lanes<W> v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

template <int W>
[[gnu::always_inline]] inline double sum(const Lanes<W>& v) noexcept {
  double s = v[0];
  for (int l = 1; l < W; ++l) s += v[l];
  return s;
}

// Everything that enters M, h and g, summed lane by lane over the chains.
template <int W>
struct Sums {
  Lanes<W> m00{}, m01{}, m02{}, m11{}, m12{}, m22{}, h0{}, h1{}, h2{}, g0{}, g1{}, g2{};
};

// update_dynamics' per-chain terms for chains [first, first + W) (the comments in
// kinematics.cpp and dynamics.cpp derive each line).
template <int W>
[[gnu::always_inline]] inline Status chain_lanes(const LaneDynamics::Chains& ch, int first, int n,
                                                 const Pose& X, double c, double s,
                                                 const Twist& X_dot, const Vec2& gravity,
                                                 Sums<W>& S, LaneDynamics::Output& out) noexcept {
  using V = Lanes<W>;
  const double xd = X_dot.x(), yd = X_dot.y(), thd = X_dot.z();
  const V ax_ = load<W>(ch.anchor_x + first), ay_ = load<W>(ch.anchor_y + first);
  // Positions (chain_geometry in kinematics.cpp): C = p + R c_i, d = C - A, the crank a = k d + s m
  // E d as the intersection of the two circles, the coupler u = d - a.
  const V rx = c * ax_ - s * ay_, ry = s * ax_ + c * ay_;
  const V dx = X.x() + rx - load<W>(ch.base_x + first);
  const V dy = X.y() + ry - load<W>(ch.base_y + first);
  const V dd = dx * dx + dy * dy;
  const V inv_dd = 1.0 / dd;
  const V k = (load<W>(ch.l1_sq_minus_l2_sq + first) + dd) * 0.5 * inv_dd;
  const V m2 = load<W>(ch.l1_sq + first) * inv_dd - k * k;
  V m;
  for (int l = 0; l < W; ++l) {
    if (!(dd[l] > 0.0 && m2[l] >= 0.0)) return Status::kUnreachable;
    m[l] = std::sqrt(m2[l]);
  }
  m *= load<W>(ch.mode + first);
  const V ax = k * dx - m * dy, ay = k * dy + m * dx;
  const V ux = dx - ax, uy = dy - ay;
  // Velocity closure (jacobian in kinematics.cpp): jm = [u^T, r x u] / (a x u), q_dot = jm X_dot,
  // and qb = Jm_dot's row times X_dot.
  const V den = ax * uy - ay * ux;
  const V limit = load<W>(ch.serial_limit_sq + first);
  for (int l = 0; l < W; ++l)
    if (!(den[l] * den[l] >= limit[l])) return Status::kSerialSingular;
  const V inv_den = 1.0 / den;
  const V j0 = ux * inv_den, j1 = uy * inv_den, j2 = (rx * uy - ry * ux) * inv_den;
  const V qd = j0 * xd + j1 * yd + j2 * thd;
  const V rdx = -thd * ry, rdy = thd * rx;  // r_dot = theta_dot E r
  const V adx = -qd * ay, ady = qd * ax;    // a_dot = q_dot E a
  const V udx = xd + rdx - adx, udy = yd + rdy - ady;
  const V num_dot2 = rdx * uy - rdy * ux + rx * udy - ry * udx;
  const V den_dot = adx * uy - ady * ux + ax * udy - ay * udx;
  const V qb = (udx * xd + udy * yd + num_dot2 * thd - qd * den_dot) * inv_den;
  // Coupler angle: phi_dot = w X_dot with w = ((-u_y, u_x, u . r) - (u . a) jm) / l2^2,
  // its bias bphi = (E u)^T (bias_C - bias_B) / l2^2.
  const V inv_uu = load<W>(ch.inv_l2_sq + first);
  const V ua = ux * ax + uy * ay, ur = ux * rx + uy * ry;
  const V w0 = (-uy - ua * j0) * inv_uu, w1 = (ux - ua * j1) * inv_uu;
  const V w2 = (ur - ua * j2) * inv_uu;
  const V bBx = -qb * ay - qd * qd * ax, bBy = qb * ax - qd * qd * ay;
  const V bCx = -thd * thd * rx, bCy = -thd * thd * ry;
  const V bphi = (-uy * (bCx - bBx) + ux * (bCy - bBy)) * inv_uu;
  // Crank rotation I_A jm jm^T and coupler rotation J w w^T, with their biases.
  const V IA = load<W>(ch.crank_inertia + first), J = load<W>(ch.coupler_inertia + first);
  const V a0 = IA * j0, a1 = IA * j1, a2 = IA * j2;
  const V e0 = J * w0, e1 = J * w1, e2 = J * w2;
  S.m00 += a0 * j0 + e0 * w0;
  S.m01 += a0 * j1 + e0 * w1;
  S.m02 += a0 * j2 + e0 * w2;
  S.m11 += a1 * j1 + e1 * w1;
  S.m12 += a1 * j2 + e1 * w2;
  S.m22 += a2 * j2 + e2 * w2;
  S.h0 += a0 * qb + e0 * bphi;
  S.h1 += a1 * qb + e1 * bphi;
  S.h2 += a2 * qb + e2 * bphi;
  if (gravity.x() != 0.0 || gravity.y() != 0.0) {
    // (E (m rc + mB a)) . gravity: the crank-frame moment rotated along a.
    const V gx = load<W>(ch.gravity_moment_x + first), gy = load<W>(ch.gravity_moment_y + first);
    const V wx = ax * gx - ay * gy, wy = ay * gx + ax * gy;
    const V wg = wx * gravity.y() - wy * gravity.x();
    S.g0 -= wg * j0;
    S.g1 -= wg * j1;
    S.g2 -= wg * j2;
  }
  for (int l = 0; l < W && first + l < n; ++l) {
    out.jm0[first + l] = j0[l];
    out.jm1[first + l] = j1[l];
    out.jm2[first + l] = j2[l];
    out.q_dot[first + l] = qd[l];
  }
  return Status::kOk;
}

template <int W>
[[gnu::always_inline]] inline Status update_lanes(const LaneDynamics::Chains& chains,
                                                  const LaneDynamics::Plate& plate,
                                                  const Vec2& gravity, int n, const Pose& X,
                                                  const Twist& X_dot,
                                                  LaneDynamics::Output& out) noexcept {
  if (!X.allFinite() || !X_dot.allFinite()) return Status::kInvalidInput;
  const double c = std::cos(X.z()), s = std::sin(X.z());
  Sums<W> S;
  for (int first = 0; first < n; first += W)
    if (const Status st = chain_lanes<W>(chains, first, n, X, c, s, X_dot, gravity, S, out);
        st != Status::kOk)
      return st;
  // The plate with its riders: first moment in the world R sP, bias -theta_dot^2 R sP.
  const double thd = X_dot.z();
  const double swx = c * plate.moment_x - s * plate.moment_y;
  const double swy = s * plate.moment_x + c * plate.moment_y;
  const double M00 = sum<W>(S.m00) + plate.mass, M11 = sum<W>(S.m11) + plate.mass;
  const double M01 = sum<W>(S.m01), M02 = sum<W>(S.m02) - swy, M12 = sum<W>(S.m12) + swx;
  const double M22 = sum<W>(S.m22) + plate.inertia;
  out.M << M00, M01, M02, M01, M11, M12, M02, M12, M22;
  out.bias << sum<W>(S.h0) - thd * thd * swx, sum<W>(S.h1) - thd * thd * swy, sum<W>(S.h2);
  if (gravity.x() != 0.0 || gravity.y() != 0.0) {
    out.bias[0] += sum<W>(S.g0) - plate.mass * gravity.x();
    out.bias[1] += sum<W>(S.g1) - plate.mass * gravity.y();
    out.bias[2] += sum<W>(S.g2) + swy * gravity.x() - swx * gravity.y();
  }
  return Status::kOk;
}

// The two builds of the same code: AVX2 + FMA (x86-64-v3: 4 chains per register, fused
// multiply-adds) and the baseline (SSE2 on x86-64, NEON on arm64: 2 chains per register).
#if defined(__x86_64__)
[[gnu::target("arch=x86-64-v3")]] Status update_avx2(const LaneDynamics::Chains& chains,
                                                     const LaneDynamics::Plate& plate,
                                                     const Vec2& gravity, int n, const Pose& X,
                                                     const Twist& X_dot,
                                                     LaneDynamics::Output& out) noexcept {
  return update_lanes<4>(chains, plate, gravity, n, X, X_dot, out);
}

bool cpu_has_avx2() noexcept {
  __builtin_cpu_init();
#if defined(__clang__) && __clang_major__ < 16
  // clang before 16 (Debian 12's, which builds fuzz/) does not know the level name: its
  // features one by one, the three __builtin_cpu_supports lacks from cpuid.
  unsigned a = 0, b = 0, c1 = 0, c8 = 0, d = 0;
  if (!__get_cpuid(1, &a, &b, &c1, &d) || !__get_cpuid(0x80000001u, &a, &b, &c8, &d)) return false;
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
         __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2") && (c1 & bit_F16C) != 0 &&
         (c1 & bit_MOVBE) != 0 && (c8 & bit_LZCNT) != 0;
#else
  return __builtin_cpu_supports("x86-64-v3");
#endif
}
#else
bool cpu_has_avx2() noexcept { return false; }
#endif

Status update_baseline(const LaneDynamics::Chains& chains, const LaneDynamics::Plate& plate,
                       const Vec2& gravity, int n, const Pose& X, const Twist& X_dot,
                       LaneDynamics::Output& out) noexcept {
  return update_lanes<2>(chains, plate, gravity, n, X, X_dot, out);
}

}  // namespace

bool LaneDynamics::supports(const Model& model) noexcept {
  if (model.n < 3 || model.n > kMaxChains) return false;
  for (int i = 0; i < model.n; ++i)
    if (model.chains[i].coupler.com.y() != 0.0) return false;
  return true;
}

LaneDynamics::LaneDynamics(const Model& model, bool allow_avx2) : n_(model.n) {
  if (model.n < 3 || model.n > kMaxChains)
    throw std::invalid_argument("LaneDynamics: the model has " + std::to_string(model.n) +
                                " chains, expected 3.." + std::to_string(kMaxChains));
  if (!supports(model))
    throw std::invalid_argument(
        "LaneDynamics: a coupler's centre of mass is off its axis (com.y != 0); use "
        "update_dynamics");
  avx2_ = allow_avx2 && cpu_has_avx2();
  const Body& p = model.plate;
  plate_ = {p.mass, p.mass * p.com.x(), p.mass * p.com.y(),
            p.inertia + p.mass * p.com.squaredNorm()};
  for (int i = 0; i < kMaxChains; ++i) {
    const bool real = i < n_;
    const Chain& ch = model.chains[real ? i : 0];
    const double l1 = ch.crank_length, l2 = ch.coupler_length;
    chains_.base_x[i] = ch.base.x();
    chains_.base_y[i] = ch.base.y();
    chains_.anchor_x[i] = ch.plate_anchor.x();
    chains_.anchor_y[i] = ch.plate_anchor.y();
    chains_.l1_sq[i] = l1 * l1;
    chains_.l1_sq_minus_l2_sq[i] = l1 * l1 - l2 * l2;
    chains_.serial_limit_sq[i] = std::pow(kSerialSingularTolerance * l1 * l2, 2);
    chains_.mode[i] = ch.working_mode;
    chains_.inv_l2_sq[i] = 1.0 / (l2 * l2);
    if (!real) {
      chains_.crank_inertia[i] = chains_.coupler_inertia[i] = 0.0;
      chains_.gravity_moment_x[i] = chains_.gravity_moment_y[i] = 0.0;
      continue;
    }
    // The coupler split (supports(): every one is): the elbow share turns with the crank,
    // the anchor share rides on the plate.
    const Body& cr = ch.crank;
    const ChainInertia ci = chain_inertia(ch);
    const double mB = ci.elbow_mass, mC = ci.anchor_mass;
    chains_.crank_inertia[i] = ci.crank_about_axis;
    chains_.coupler_inertia[i] = ci.coupler_rotary;
    chains_.gravity_moment_x[i] = (cr.mass * cr.com.x() + mB * l1) / l1;
    chains_.gravity_moment_y[i] = cr.mass * cr.com.y() / l1;
    plate_.mass += mC;
    plate_.moment_x += mC * ch.plate_anchor.x();
    plate_.moment_y += mC * ch.plate_anchor.y();
    plate_.inertia += mC * ch.plate_anchor.squaredNorm();
  }
  gravity_ = model.gravity;
}

Status LaneDynamics::update(const Pose& X, const Twist& X_dot, Output& out) const noexcept {
#if defined(__x86_64__)
  if (avx2_) return update_avx2(chains_, plate_, gravity_, n_, X, X_dot, out);
#endif
  return update_baseline(chains_, plate_, gravity_, n_, X, X_dot, out);
}

}  // namespace dualv::model
