#pragma once
// The excitation program for identification (issue 16): the plate follows a finite Fourier
// series in each coordinate,
//   c(lambda) = home_c + sum_{k=1..H} a_k cos(k lambda) + b_k sin(k lambda),
// which is the paper's eq. 4 shape with powers 1 and integer frequencies (a custom shape of
// control/trajectory/shape.hpp), travelled `periods` times at the cruise speed 2 pi / period
// by the C3 timing law (kSmooth: at rest at both ends), between PtP moves from and back to home.
// So it runs like any program, in the simulation or on the drives, and is pre-flighted as any.
//
// The coefficients are chosen by a seeded random search with local refinement to minimise the
// condition number of the base parameters' regressor (column-scaled) over one period, each
// candidate scaled to stay inside the workspace amplitudes given and within a fraction of
// every trajectory limit (joint speed, plate acceleration, torque from the nominal model).
// Set-up code.
#include <array>
#include <cstdint>

#include "control/identification/base_parameters.hpp"
#include "control/model/model.hpp"
#include "control/trajectory/limits.hpp"
#include "control/trajectory/program.hpp"

namespace dualv::identification {

struct ExcitationConfig {
  double period = 2.0;                     // [s] of the fundamental
  int harmonics = 4;                       // H, 1..trajectory::kMaxTerms
  int periods = 3;                         // cruise periods
  double blend = 0.3;                      // [s] ramp of the timing law at each end
  model::Pose amplitude{0.02, 0.02, 0.1};  // largest excursion from home [m, m, rad]
  double limit_fraction = 0.5;             // of each trajectory limit
  double ptp_duration = 1.0;               // [s] moves from home and back
  int candidates = 60;                     // random starts
  int refinements = 60;                    // local perturbations of the best
  std::uint64_t seed = 16;
};

struct Excitation {
  trajectory::Program program;
  std::size_t shape_segment = 1;  // the Fourier segment's index in program
  // Fourier coefficients per coordinate: a_k, b_k (k = 1..H) [m or rad].
  std::array<Eigen::VectorXd, 3> a, b;
  double condition = 0.0;  // scaled condition number of the base regressor over one period
  double scale = 1.0;      // amplitude factor the limits allowed (1: the amplitudes given)
};

// Throws std::runtime_error when no candidate fits the limits, trajectory::PreflightError when
// the final program does not pass pre-flight.
Excitation design_excitation(const model::Model& model, const BaseParameters& base,
                             const trajectory::Limits& limits, const ExcitationConfig& config);

// The scaled condition number of the base regressor along one period of a Fourier motion.
double excitation_condition(const model::Model& model, const BaseParameters& base,
                            const trajectory::Shape& shape, double period, int samples = 120);

}  // namespace dualv::identification
