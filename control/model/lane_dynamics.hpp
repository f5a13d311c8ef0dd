#pragma once
// update_dynamics (control/model/dynamics.hpp) with the chains side by side in SIMD lanes:
// the plant's right-hand side, evaluated 40 000 times per simulated second by its RK4.
//
// The chains are identical closed loops, so every chain's position, velocity closure and
// mass terms are the same arithmetic on different numbers: two chains per SSE2 register
// (baseline x86-64), four per AVX2 register where the CPU has AVX2 and FMA (chosen at
// construction). The model's constants are folded once. The equations are
// update_dynamics' (tests hold the two to agreement near round-off); the couplers must
// have their centres of mass on their axes (supports()), which makes each coupler exactly
// two point masses and a rotary inertia. Real-time safe: update() is noexcept and
// allocation-free.
#include <array>

#include "control/model/model.hpp"

namespace dualv::model {

class LaneDynamics {
 public:
  // True when the model has 3..kMaxChains chains and every coupler's centre of mass lies on
  // its axis (com.y == 0), as in the Dual-V; otherwise use update_dynamics.
  static bool supports(const Model& model) noexcept;

  // Set-up: throws std::invalid_argument naming the reason when !supports(model).
  // `allow_avx2` false keeps the baseline (SSE2) code path (tests run both).
  explicit LaneDynamics(const Model& model, bool allow_avx2 = true);

  struct Output {
    Mat3 M = Mat3::Zero();       // task-space mass matrix
    Twist bias = Twist::Zero();  // h + g: F_X = M X_dd + bias
    // Jm (row i: chain i) and q_dot = Jm X_dot [rad/s].
    std::array<double, kMaxChains> jm0{}, jm1{}, jm2{}, q_dot{};
  };

  // M, h + g, Jm and q_dot at (X, X_dot). kInvalidInput for non-finite input, kUnreachable
  // or kSerialSingular as update_dynamics; `out` is then unspecified.
  Status update(const Pose& X, const Twist& X_dot, Output& out) const noexcept;

  bool uses_avx2() const noexcept { return avx2_; }

  // Per-chain constants, one array per quantity (lanes load them side by side). Entries past
  // n repeat chain 0's geometry with no mass: reachable exactly when chain 0 is, adding
  // nothing.
  struct Chains {
    alignas(32) double base_x[kMaxChains], base_y[kMaxChains];            // A_i [m]
    alignas(32) double anchor_x[kMaxChains], anchor_y[kMaxChains];        // c_i, plate frame [m]
    alignas(32) double l1_sq[kMaxChains], l1_sq_minus_l2_sq[kMaxChains];  // [m^2]
    alignas(32) double serial_limit_sq[kMaxChains];  // (kSerialSingularTolerance l1 l2)^2 [m^4]
    alignas(32) double mode[kMaxChains];             // working mode s_i = +-1
    alignas(32) double inv_l2_sq[kMaxChains];        // 1 / l2^2 [1/m^2]
    alignas(32) double crank_inertia[kMaxChains];    // I_A: crank + coupler's elbow share
    alignas(32) double coupler_inertia[kMaxChains];  // J: coupler's rotary share [kg m^2]
    // (m rc + mB (l1, 0)) / l1 in the crank frame [kg]: the crank's gravity moment.
    alignas(32) double gravity_moment_x[kMaxChains], gravity_moment_y[kMaxChains];
  };

  // The plate with the couplers' anchor shares riding on it, about the plate origin.
  struct Plate {
    double mass = 0.0, moment_x = 0.0, moment_y = 0.0;  // first moment, plate frame [kg m]
    double inertia = 0.0;                               // about the origin [kg m^2]
  };

 private:
  int n_ = 0;
  bool avx2_ = false;
  Chains chains_{};
  Plate plate_;
  Vec2 gravity_ = Vec2::Zero();
};

}  // namespace dualv::model
