#pragma once
// Frames as the slave parts' tests write them by hand: "ID#DATA" in hex, candump's compact form
// (e.g. "08A#1042090000000000"), and a FrameSink that records what a part sends in that form.
#include <cstdio>
#include <string>
#include <vector>

#include "firmware_if/can_frame.hpp"
#include "sim/canopen/frame_sink.hpp"

namespace dualv::sim::canopen::test {

inline std::string text(const fw::CanFrame& f) {
  char b[8];
  std::snprintf(b, sizeof b, "%03X#", f.id);
  std::string s = b;
  for (int i = 0; i < f.dlc; ++i) {
    std::snprintf(b, sizeof b, "%02X", f.data[static_cast<std::size_t>(i)]);
    s += b;
  }
  return s;
}

struct FrameRecorder final : FrameSink {
  std::vector<std::string> frames;
  void send(const fw::CanFrame& f) noexcept override { frames.push_back(text(f)); }
};

}  // namespace dualv::sim::canopen::test
