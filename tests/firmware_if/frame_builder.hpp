#pragma once
// Golden frames for the firmware_if tests: written by hand, byte by byte, from CiA 301/402.
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <ostream>

#include "firmware_if/can_frame.hpp"
#include "firmware_if/result.hpp"

namespace dualv::fw::test {

inline CanFrame make_frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  CanFrame f;
  f.id = id;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  std::uint8_t i = 0;
  for (std::uint8_t b : bytes) f.data[i++] = b;
  return f;
}

}  // namespace dualv::fw::test

namespace dualv::fw {
// Readable failure messages.
inline std::ostream& operator<<(std::ostream& os, const CanFrame& f) {
  os << "id=0x" << std::hex << f.id << " dlc=" << std::dec << int(f.dlc) << " [";
  for (std::size_t i = 0; i < f.dlc && i < 8; ++i)
    os << (i ? " " : "") << std::hex << int(f.data[i]);
  return os << std::dec << "]" << (f.extended ? " ext" : "") << (f.rtr ? " rtr" : "");
}
inline std::ostream& operator<<(std::ostream& os, Error e) { return os << to_string(e); }
}  // namespace dualv::fw
