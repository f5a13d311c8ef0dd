#include "drivers/can/socketcan_error.hpp"

#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>

#include <string>

namespace dualv::drivers {
namespace {

std::string text(const CanErrorReport& r) {
  char buf[128];
  return describe(r, buf, sizeof(buf));
}

TEST(CanErrorDecode, BusOff) {
  const auto r = decode_can_error(CAN_ERR_FLAG | CAN_ERR_BUSOFF, {});
  EXPECT_TRUE(r.bus_off);
  EXPECT_FALSE(r.error_passive);
  EXPECT_EQ(text(r), "bus-off");
}

TEST(CanErrorDecode, ControllerErrorPassiveWithCounters) {
  std::array<std::uint8_t, 8> d{};
  d[1] = CAN_ERR_CRTL_TX_PASSIVE;
  d[6] = 130;
  d[7] = 4;
  const auto r = decode_can_error(CAN_ERR_FLAG | CAN_ERR_CRTL | CAN_ERR_CNT, d);
  EXPECT_TRUE(r.controller);
  EXPECT_TRUE(r.error_passive);
  EXPECT_FALSE(r.warning);
  ASSERT_TRUE(r.has_counters);
  EXPECT_EQ(r.tx_error_counter, 130);
  EXPECT_EQ(r.rx_error_counter, 4);
  EXPECT_EQ(text(r), "error-passive(tx=130 rx=4)");
}

TEST(CanErrorDecode, ControllerDetails) {
  std::array<std::uint8_t, 8> d{};
  d[1] = CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_RX_OVERFLOW;
  auto r = decode_can_error(CAN_ERR_FLAG | CAN_ERR_CRTL, d);
  EXPECT_TRUE(r.warning);
  EXPECT_TRUE(r.rx_overflow);
  EXPECT_FALSE(r.tx_overflow);
  d[1] = CAN_ERR_CRTL_ACTIVE;
  r = decode_can_error(CAN_ERR_FLAG | CAN_ERR_CRTL, d);
  EXPECT_TRUE(r.back_to_active);
  EXPECT_EQ(text(r), "error-active");
  d[1] = CAN_ERR_CRTL_UNSPEC;
  r = decode_can_error(CAN_ERR_FLAG | CAN_ERR_CRTL, d);
  EXPECT_EQ(text(r), "controller");
}

TEST(CanErrorDecode, ControllerBytesIgnoredWithoutTheClass) {
  std::array<std::uint8_t, 8> d{};
  d[1] = CAN_ERR_CRTL_TX_PASSIVE;
  d[6] = 200;
  const auto r = decode_can_error(CAN_ERR_FLAG | CAN_ERR_ACK, d);
  EXPECT_FALSE(r.error_passive);
  EXPECT_FALSE(r.has_counters);
  EXPECT_TRUE(r.no_ack);
  EXPECT_EQ(text(r), "no-ack");
}

TEST(CanErrorDecode, ProtocolAndOthers) {
  std::array<std::uint8_t, 8> d{};
  d[2] = CAN_ERR_PROT_STUFF;
  d[3] = CAN_ERR_PROT_LOC_CRC_SEQ;
  const auto r =
      decode_can_error(CAN_ERR_FLAG | CAN_ERR_PROT | CAN_ERR_TX_TIMEOUT | CAN_ERR_LOSTARB |
                           CAN_ERR_TRX | CAN_ERR_BUSERROR | CAN_ERR_RESTARTED,
                       d);
  EXPECT_TRUE(r.protocol);
  EXPECT_EQ(r.protocol_type, CAN_ERR_PROT_STUFF);
  EXPECT_EQ(r.protocol_location, CAN_ERR_PROT_LOC_CRC_SEQ);
  EXPECT_TRUE(r.tx_timeout);
  EXPECT_TRUE(r.lost_arbitration);
  EXPECT_TRUE(r.transceiver);
  EXPECT_TRUE(r.bus_error);
  EXPECT_TRUE(r.restarted);
  EXPECT_EQ(text(r), "restarted,tx-timeout,lost-arbitration,protocol,transceiver,bus-error");
}

TEST(CanErrorDecode, EmptyClassAndTinyBuffers) {
  const auto r = decode_can_error(CAN_ERR_FLAG, {});
  EXPECT_EQ(text(r), "unspecified");
  char small[4];
  EXPECT_STREQ(describe(decode_can_error(CAN_ERR_FLAG | CAN_ERR_BUSOFF, {}), small, 4), "bus");
  EXPECT_EQ(describe(r, nullptr, 0), nullptr);
}

}  // namespace
}  // namespace dualv::drivers
