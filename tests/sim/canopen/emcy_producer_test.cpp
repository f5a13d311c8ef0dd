// The EMCY producer part of the emulated slave (sim/canopen/emcy_producer.hpp): every frame
// written by hand from CiA 301 7.2.7 (080h + node, code LE, error register 1001h, five
// zero bytes) and 7.5.2.2 (1001h bits: 0 generic, 3 temperature, 4 communication).
#include "sim/canopen/emcy_producer.hpp"

#include <gtest/gtest.h>

#include "tests/sim/canopen/frame_text.hpp"

#include <cstdio>
#include <string>
#include <vector>

namespace dualv::sim::canopen {
namespace {

using Recorder = test::FrameRecorder;
using test::text;

struct Emcy : ::testing::Test {
  ObjectDictionary od;
  EmcyProducer producer;
  Recorder bus;
  int s_reg = -1;
  void SetUp() override {
    s_reg = od.add(fw::od::kErrorRegister, 0);
    producer.attach(5, s_reg);
  }
};

TEST_F(Emcy, EveryEmcyCarriesTheErrorRegisterAndClearsByTheStandard) {
  producer.raise(od, 0, 0x8210, true, bus);  // PDO length: generic + communication = 11h
  EXPECT_EQ(od.u(s_reg), 0x11u);
  producer.raise(od, 1, 0x4210, true, bus);  // device over-temperature: + 08h
  EXPECT_EQ(od.u(s_reg), 0x19u);
  producer.clear(od, 0, true, bus);  // 0000h with what remains: generic + temperature
  EXPECT_EQ(od.u(s_reg), 0x09u);
  producer.clear(od, 1, true, bus);
  EXPECT_EQ(od.u(s_reg), 0x00u);
  EXPECT_EQ(bus.frames, (std::vector<std::string>{"085#1082110000000000", "085#1042190000000000",
                                                  "085#0000090000000000", "085#0000000000000000"}));
  EXPECT_EQ(producer.sent(), 4u);
}

TEST_F(Emcy, ClearingWhatIsNotActiveSendsNothing) {
  producer.clear(od, 2, true, bus);
  EXPECT_TRUE(bus.frames.empty());
}

TEST_F(Emcy, UnannouncedConditionsUpdateTheRegisterOnly) {
  producer.raise(od, 3, 0x8130, false, bus);  // e.g. NMT Stopped: no EMCY (CiA 301 table 75)
  EXPECT_TRUE(bus.frames.empty());
  EXPECT_EQ(od.u(s_reg), 0x11u);
  EXPECT_TRUE(producer.active(3));
  producer.raise(od, 4, 0x2310, true, bus);  // current: 02h; the register shows both
  EXPECT_EQ(bus.frames, (std::vector<std::string>{"085#1023130000000000"}));
  producer.reset();
  EXPECT_EQ(producer.error_register(), 0u);
  EXPECT_FALSE(producer.active(3));
}

TEST(ErrorRegisterBits, FollowTheCodesClass) {
  EXPECT_EQ(error_register_bits(0x1000), 0x01);  // generic
  EXPECT_EQ(error_register_bits(0x2310), 0x03);  // current
  EXPECT_EQ(error_register_bits(0x3210), 0x05);  // voltage
  EXPECT_EQ(error_register_bits(0x4310), 0x09);  // temperature
  EXPECT_EQ(error_register_bits(0x8130), 0x11);  // communication
  EXPECT_EQ(error_register_bits(0xFF00), 0x01);  // device specific: generic only
}

}  // namespace
}  // namespace dualv::sim::canopen
