#pragma once
// Decoding of SocketCAN error frames (linux/can/error.h), kept apart from the socket so it
// can be tested without a CAN-enabled kernel. Real-time safe: pure, noexcept.
#include <array>
#include <cstddef>
#include <cstdint>

namespace dualv::drivers {

// What one error frame says. Several classes may be set in one frame.
struct CanErrorReport {
  bool tx_timeout = false;             // CAN_ERR_TX_TIMEOUT
  bool lost_arbitration = false;       // CAN_ERR_LOSTARB (data[0]: bit position)
  bool controller = false;             // CAN_ERR_CRTL (details below)
  bool rx_overflow = false;            //   controller RX buffer overflow
  bool tx_overflow = false;            //   controller TX buffer overflow
  bool warning = false;                //   RX or TX error counter reached the warning level (96)
  bool error_passive = false;          //   RX or TX error counter reached error passive (128)
  bool back_to_active = false;         //   recovered to error active
  bool protocol = false;               // CAN_ERR_PROT: bit, form, stuff errors (data[2..3])
  std::uint8_t protocol_type = 0;      // data[2], CAN_ERR_PROT_* bits
  std::uint8_t protocol_location = 0;  // data[3], CAN_ERR_PROT_LOC_*
  bool transceiver = false;            // CAN_ERR_TRX (data[4]: wiring fault)
  bool no_ack = false;                 // CAN_ERR_ACK: nobody acknowledged (no other node, cable)
  bool bus_off = false;                // CAN_ERR_BUSOFF
  bool bus_error = false;              // CAN_ERR_BUSERROR
  bool restarted = false;              // CAN_ERR_RESTARTED: the controller left bus-off
  bool has_counters = false;           // CAN_ERR_CNT: tx/rx error counters are valid
  std::uint8_t tx_error_counter = 0;   // data[6]
  std::uint8_t rx_error_counter = 0;   // data[7]
};

// can_id: the raw SocketCAN id with CAN_ERR_FLAG set (flags are ignored); data: the 8 bytes.
CanErrorReport decode_can_error(std::uint32_t can_id,
                                const std::array<std::uint8_t, 8>& data) noexcept;

// One line for logs and tests, e.g. "bus-off", "error-passive(tx=128 rx=0)", "no-ack";
// written into buf (NUL-terminated, truncated to size). Returns buf.
const char* describe(const CanErrorReport& r, char* buf, std::size_t size) noexcept;

}  // namespace dualv::drivers
