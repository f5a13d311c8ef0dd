// The NMT slave part of the emulated slave (sim/canopen/nmt_slave.hpp): states and what
// they allow from CiA 301 7.3.2 (figure 48, table 75), boot-up and heartbeat frames written
// by hand from 7.2.8.3.2 (700h + node; 00h boot-up, 7Fh pre-operational, 05h operational,
// 04h stopped), the producer period 1017h checked at T - 1 ns and T.
#include "sim/canopen/nmt_slave.hpp"

#include <gtest/gtest.h>

#include "tests/sim/canopen/frame_text.hpp"

#include <cstdio>
#include <string>
#include <vector>

namespace dualv::sim::canopen {
namespace {

using Recorder = test::FrameRecorder;
using test::text;

constexpr std::uint64_t kMs = 1'000'000;

struct Nmt : ::testing::Test {
  ObjectDictionary od;
  NmtSlave nmt;
  Recorder bus;
  int s_hb = -1;
  void SetUp() override {
    s_hb = od.add(fw::od::kProducerHeartbeat, 100);  // 100 ms
    nmt.attach(0x12, s_hb);
  }
};

TEST_F(Nmt, BootsWithTheBootUpMessageIntoPreOperational) {
  EXPECT_EQ(nmt.state(), NmtSlaveState::kInitialisation);
  EXPECT_FALSE(nmt.sdo_allowed());
  EXPECT_EQ(nmt.on_command(fw::NmtCommand::kStart).to, NmtSlaveState::kInitialisation);
  nmt.boot_up(od, 0, bus);
  EXPECT_EQ(bus.frames, (std::vector<std::string>{"712#00"}));
  EXPECT_EQ(nmt.state(), NmtSlaveState::kPreOperational);
  EXPECT_TRUE(nmt.sdo_allowed());
  EXPECT_TRUE(nmt.emcy_allowed());
  EXPECT_FALSE(nmt.pdo_allowed());
}

TEST_F(Nmt, HeartbeatAtTheProducerTimeWithTheState) {
  nmt.boot_up(od, 0, bus);
  bus.frames.clear();
  EXPECT_EQ(nmt.next_due_ns(od), 100 * kMs);
  EXPECT_FALSE(nmt.on_time(od, 100 * kMs - 1, bus));  // T - 1 ns
  EXPECT_TRUE(nmt.on_time(od, 100 * kMs, bus));       // T
  nmt.on_command(fw::NmtCommand::kStart);
  EXPECT_FALSE(nmt.on_time(od, 200 * kMs - 1, bus));
  EXPECT_TRUE(nmt.on_time(od, 200 * kMs, bus));
  nmt.on_command(fw::NmtCommand::kStop);
  EXPECT_TRUE(nmt.on_time(od, 300 * kMs, bus));
  EXPECT_EQ(bus.frames, (std::vector<std::string>{"712#7F", "712#05", "712#04"}));
}

TEST_F(Nmt, WritingTheProducerTimeRestartsIt) {
  nmt.boot_up(od, 0, bus);
  od.set(s_hb, 0);
  nmt.producer_time_written(od, 50 * kMs);
  EXPECT_EQ(nmt.next_due_ns(od), NmtSlave::kNever);  // 0 = off
  EXPECT_FALSE(nmt.on_time(od, 1000 * kMs, bus));
  od.set(s_hb, 20);
  nmt.producer_time_written(od, 1000 * kMs);
  EXPECT_FALSE(nmt.on_time(od, 1020 * kMs - 1, bus));
  EXPECT_TRUE(nmt.on_time(od, 1020 * kMs, bus));
}

TEST_F(Nmt, StatesGateSdoEmcyAndPdo) {
  nmt.boot_up(od, 0, bus);
  NmtChange c = nmt.on_command(fw::NmtCommand::kStart);
  EXPECT_EQ(c.from, NmtSlaveState::kPreOperational);
  EXPECT_TRUE(nmt.pdo_allowed());
  EXPECT_TRUE(nmt.sdo_allowed());
  c = nmt.on_command(fw::NmtCommand::kStop);
  EXPECT_TRUE(c.left_operational());
  EXPECT_FALSE(nmt.pdo_allowed());
  EXPECT_FALSE(nmt.sdo_allowed());  // Stopped: NMT and heartbeat only
  EXPECT_FALSE(nmt.emcy_allowed());
  c = nmt.on_command(fw::NmtCommand::kEnterPreOperational);
  EXPECT_EQ(c.to, NmtSlaveState::kPreOperational);
  EXPECT_FALSE(c.left_operational());
}

TEST_F(Nmt, ResetsGoThroughInitialisation) {
  nmt.boot_up(od, 0, bus);
  nmt.on_command(fw::NmtCommand::kStart);
  NmtChange c = nmt.on_command(fw::NmtCommand::kResetNode);
  EXPECT_TRUE(c.reset_application);
  EXPECT_EQ(nmt.state(), NmtSlaveState::kInitialisation);
  EXPECT_EQ(nmt.next_due_ns(od), NmtSlave::kNever);  // no heartbeat in Initialisation
  nmt.boot_up(od, 10 * kMs, bus);
  c = nmt.on_command(fw::NmtCommand::kResetCommunication);
  EXPECT_TRUE(c.reset_communication);
  EXPECT_FALSE(c.reset_application);
  nmt.boot_up(od, 20 * kMs, bus);
  EXPECT_EQ(bus.frames, (std::vector<std::string>{"712#00", "712#00", "712#00"}));
  EXPECT_EQ(nmt.next_due_ns(od), 120 * kMs);
}

}  // namespace
}  // namespace dualv::sim::canopen
