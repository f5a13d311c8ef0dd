#include "drivers/can/socketcan_error.hpp"

#include <linux/can.h>
#include <linux/can/error.h>

#include <cstdio>

namespace dualv::drivers {

CanErrorReport decode_can_error(std::uint32_t can_id,
                                const std::array<std::uint8_t, 8>& data) noexcept {
  CanErrorReport r;
  const std::uint32_t cls = can_id & CAN_ERR_MASK;
  r.tx_timeout = (cls & CAN_ERR_TX_TIMEOUT) != 0;
  r.lost_arbitration = (cls & CAN_ERR_LOSTARB) != 0;
  r.controller = (cls & CAN_ERR_CRTL) != 0;
  if (r.controller) {
    const std::uint8_t c = data[1];
    r.rx_overflow = (c & CAN_ERR_CRTL_RX_OVERFLOW) != 0;
    r.tx_overflow = (c & CAN_ERR_CRTL_TX_OVERFLOW) != 0;
    r.warning = (c & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0;
    r.error_passive = (c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0;
    r.back_to_active = (c & CAN_ERR_CRTL_ACTIVE) != 0;
  }
  r.protocol = (cls & CAN_ERR_PROT) != 0;
  if (r.protocol) {
    r.protocol_type = data[2];
    r.protocol_location = data[3];
  }
  r.transceiver = (cls & CAN_ERR_TRX) != 0;
  r.no_ack = (cls & CAN_ERR_ACK) != 0;
  r.bus_off = (cls & CAN_ERR_BUSOFF) != 0;
  r.bus_error = (cls & CAN_ERR_BUSERROR) != 0;
  r.restarted = (cls & CAN_ERR_RESTARTED) != 0;
  r.has_counters = (cls & CAN_ERR_CNT) != 0;
  if (r.has_counters) {
    r.tx_error_counter = data[6];
    r.rx_error_counter = data[7];
  }
  return r;
}

const char* describe(const CanErrorReport& r, char* buf, std::size_t size) noexcept {
  if (buf == nullptr || size == 0) {
    return buf;
  }
  buf[0] = '\0';
  std::size_t used = 0;
  auto add = [&](const char* word) {
    if (used >= size) {
      return;
    }
    const int n = std::snprintf(buf + used, size - used, "%s%s", used == 0 ? "" : ",", word);
    if (n > 0) {
      used += static_cast<std::size_t>(n);
    }
  };
  if (r.bus_off) add("bus-off");
  if (r.error_passive) add("error-passive");
  if (r.warning) add("error-warning");
  if (r.back_to_active) add("error-active");
  if (r.restarted) add("restarted");
  if (r.no_ack) add("no-ack");
  if (r.tx_timeout) add("tx-timeout");
  if (r.lost_arbitration) add("lost-arbitration");
  if (r.rx_overflow) add("rx-overflow");
  if (r.tx_overflow) add("tx-overflow");
  if (r.controller && !r.rx_overflow && !r.tx_overflow && !r.warning && !r.error_passive &&
      !r.back_to_active) {
    add("controller");
  }
  if (r.protocol) add("protocol");
  if (r.transceiver) add("transceiver");
  if (r.bus_error) add("bus-error");
  if (r.has_counters && used < size) {
    const int n =
        std::snprintf(buf + used, size - used, "%s(tx=%u rx=%u)", used == 0 ? "counters" : "",
                      r.tx_error_counter, r.rx_error_counter);
    if (n > 0) {
      used += static_cast<std::size_t>(n);
    }
  }
  if (used == 0) {
    std::snprintf(buf, size, "unspecified");
  }
  return buf;
}

}  // namespace dualv::drivers
