#pragma once
// NMT master services (CiA 301 7.2.8.3.1): module control commands on COB-ID 000h.
// Real-time safe (noexcept, no allocation): the cycle never sends NMT, but safety may.
#include <cstdint>

#include "drivers/can/can_bus.hpp"
#include "firmware_if/nmt.hpp"

namespace dualv::drivers::canopen {

// Sends `command` to `node` (0 = all nodes). kIoError for an invalid node id.
BusStatus send_nmt(CanBus& bus, fw::NmtCommand command, std::uint8_t node) noexcept;

}  // namespace dualv::drivers::canopen
