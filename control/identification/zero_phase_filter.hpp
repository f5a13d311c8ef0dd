#pragma once
// Off-line signal processing for identification (issue 16): a Butterworth low-pass run forward
// and backward (zero phase: no delay between positions, their derivatives and the torques),
// and central differences. Set-up code (allocates): never on the real-time path.
//
// The low-pass is an even-order Butterworth made of second-order sections (bilinear transform
// with the cutoff prewarped). Run forward then backward, its gain at frequency f is exactly
//   |H(f)|^2 = 1 / (1 + (tan(pi f / fs) / tan(pi fc / fs))^(2 order))
// and its phase is zero. The ends are padded with the signal's odd reflection (constant and
// linear signals pass unchanged, to the last sample) and each section starts in the steady state
// of the first padded sample.
#include <vector>

namespace dualv::identification {

class ZeroPhaseLowPass {
 public:
  // order: even, 2..8; 0 < cutoff_hz < sample_hz / 2. Throws std::invalid_argument otherwise.
  ZeroPhaseLowPass(int order, double cutoff_hz, double sample_hz);

  std::vector<double> apply(const std::vector<double>& x) const;
  // The closed form above.
  double gain(double frequency_hz) const noexcept;
  // Samples at each end whose output the padding still influences noticeably: trim them.
  int edge_samples() const noexcept { return pad_; }

 private:
  struct Section {
    double b0, b1, b2, a1, a2;
  };
  void run(std::vector<double>& x) const;  // forward, in place
  int order_;
  double cutoff_hz_, sample_hz_;
  int pad_;
  std::vector<Section> sections_;
};

// dx/dt by central differences (x[k+1] - x[k-1]) / 2h, second-order one-sided at the ends.
std::vector<double> central_difference(const std::vector<double>& x, double h);

}  // namespace dualv::identification
