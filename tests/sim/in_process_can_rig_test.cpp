// The in-process rig: master endpoint <-> emulator <-> plant in lock-step, and a monitor
// endpoint that sees every frame on the wire.
#include "sim/in_process_can_rig.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "drivers/canopen_config.hpp"
#include "firmware_if/firmware_if.hpp"
#include "tests/sim/sim_fixture.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::sim {
namespace {

std::vector<fw::CanFrame> drain(drivers::InProcessBus& bus) {
  std::vector<fw::CanFrame> out;
  fw::CanFrame f;
  while (bus.receive(f) == drivers::BusStatus::kOk) out.push_back(f);
  return out;
}

class Rig : public ::testing::Test {
 protected:
  Rig()
      : rig(test::dual_v(), load_plant_config_file(test::config_file()),
            drivers::load_can_config_file(test::config_file())) {}
  void send(const fw::Result<fw::CanFrame>& f) {
    ASSERT_TRUE(f.ok());
    ASSERT_EQ(rig.master_bus().send(*f), drivers::BusStatus::kOk);
  }
  // A master cycle as the host would do it: RPDO1 to every drive, then SYNC.
  void master_cycle(std::uint16_t cw, const std::array<std::int16_t, 4>& tq) {
    for (std::uint8_t n = 1; n <= 4; ++n) send(fw::encode_rpdo1(n, {cw, tq[n - 1u]}));
    send(fw::encode_sync());
  }
  InProcessCanRig rig;
  static constexpr std::uint64_t kPeriod = 1'000'000;
};

TEST_F(Rig, BootsOverFramesAndClosesTheLoop) {
  rig.step(kPeriod);                              // power on
  EXPECT_EQ(drain(rig.master_bus()).size(), 4u);  // boot-ups
  for (std::uint8_t n = 1; n <= 4; ++n) {
    send(fw::sdo_download_value(n, fw::od::kModesOfOperation, 10));
    rig.step(kPeriod);
  }
  EXPECT_EQ(drain(rig.master_bus()).size(), 4u);  // SDO responses
  send(fw::encode_nmt(fw::NmtCommand::kStart, 0));
  for (const std::uint16_t cw : std::initializer_list<std::uint16_t>{0x06, 0x07, 0x0F}) {
    master_cycle(cw, {0, 0, 0, 0});
    rig.step(kPeriod);
  }
  for (int i = 0; i < 4; ++i)
    EXPECT_EQ(rig.emulator().status(i).state, fw::Cia402State::kOperationEnabled);
  drain(rig.master_bus());
  // Joint PD on drive 0 only (about 80 N m/rad, 2 N m s/rad, in counts and per mille);
  // the others hold 0 N m. The loop runs on frames; the monitor sees the wire.
  std::array<std::int32_t, 4> pos{};
  std::int32_t target = 0, start = 0, prev = 0;
  int tpdos = 0;
  std::size_t sync = 0, tpdo1 = 0, rpdo1 = 0;
  drain(rig.monitor_bus());
  for (int k = 0; k <= 300; ++k) {
    for (const fw::CanFrame& f : drain(rig.master_bus())) {
      const auto fb = fw::decode_tpdo1(f);
      if (!fb) continue;
      pos[f.id - 0x181] = fb->position;
      ++tpdos;
    }
    for (const fw::CanFrame& f : drain(rig.monitor_bus())) {
      sync += f.id == 0x080;
      tpdo1 += f.id == 0x181;
      rpdo1 += f.id == 0x201;
    }
    if (k == 300) break;  // the last cycle's frames counted
    if (k == 1) {
      start = prev = pos[0];
      target = start + 2000;  // about 12 mrad
    }
    double tq = 0.0;
    if (k >= 1) {
      tq = 0.01 * (target - pos[0]) - 0.24 * (pos[0] - prev);
      prev = pos[0];
    }
    master_cycle(0x0F, {static_cast<std::int16_t>(std::clamp(tq, -400.0, 400.0)), 0, 0, 0});
    rig.step(kPeriod);
  }
  EXPECT_EQ(tpdos, 4 * 300);  // the TPDOs of the enable cycles were drained before
  EXPECT_LT(std::abs(target - pos[0]), 600) << "start " << start << " target " << target;
  EXPECT_NEAR(rig.plant().output().time, 0.302, 1e-9);  // 303 SYNCs, the first starts time
  EXPECT_EQ(sync, 300u);
  EXPECT_EQ(tpdo1, 300u);
  EXPECT_EQ(rpdo1, 300u);
}

TEST_F(Rig, StepAllocatesNothing) {
  rig.step(kPeriod);
  send(fw::encode_nmt(fw::NmtCommand::kStart, 0));
  rig.step(kPeriod);
  drain(rig.master_bus());
  std::array<fw::CanFrame, 5> frames{};
  for (std::uint8_t n = 1; n <= 4; ++n) frames[n - 1u] = *fw::encode_rpdo1(n, {0x0F, 10});
  frames[4] = *fw::encode_sync();
  fw::CanFrame rx;
  dualv::test::start_counting();
  for (int k = 0; k < 1000; ++k) {
    for (const fw::CanFrame& f : frames) rig.master_bus().send(f);
    rig.step(kPeriod);
    while (rig.master_bus().receive(rx) == drivers::BusStatus::kOk) {
    }
    while (rig.monitor_bus().receive(rx) == drivers::BusStatus::kOk) {
    }
  }
  EXPECT_EQ(dualv::test::stop_counting(), 0);
}

}  // namespace
}  // namespace dualv::sim
