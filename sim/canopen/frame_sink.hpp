#pragma once
// Where a CANopen slave part's frames go (the emulated drive's bus, a test's recorder).
#include "firmware_if/can_frame.hpp"

namespace dualv::sim::canopen {

class FrameSink {
 public:
  virtual void send(const fw::CanFrame& frame) noexcept = 0;

 protected:
  ~FrameSink() = default;
};

}  // namespace dualv::sim::canopen
