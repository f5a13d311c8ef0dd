#pragma once
// A master endpoint and the drive emulator on an InProcessHub, with simulated time: the
// test plays the CANopen master with firmware_if's encoders and checks the exact frames.
#include <gtest/gtest.h>

#include <cstdint>
#include <initializer_list>
#include <memory>
#include <ostream>
#include <vector>

#include "drivers/can/in_process_bus.hpp"
#include "drivers/canopen_config.hpp"
#include "firmware_if/firmware_if.hpp"
#include "sim/drive_emulator.hpp"
#include "tests/sim/sim_fixture.hpp"

namespace dualv::fw {
inline void PrintTo(const CanFrame& f, std::ostream* os) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%03X#", f.id);
  *os << buf;
  for (int i = 0; i < f.dlc && i < 8; ++i) {
    std::snprintf(buf, sizeof buf, "%02X", f.data[static_cast<std::size_t>(i)]);
    *os << buf;
  }
}
}  // namespace dualv::fw

namespace dualv::sim::test {

inline fw::CanFrame frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  fw::CanFrame f;
  f.id = id;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (std::uint8_t b : bytes) f.data[i++] = b;
  return f;
}

inline constexpr std::uint64_t kMs = 1'000'000;

class EmulatorTest : public ::testing::Test {
 protected:
  static DriveEmulatorConfig default_config() {
    return emulator_config_from(drivers::default_can_config());
  }
  void SetUp() override { build(default_config()); }
  void build(const DriveEmulatorConfig& c) {
    emu.reset();
    plant.reset();
    hub.reset();
    stash.clear();
    cfg = c;
    hub = std::make_unique<drivers::InProcessHub>(2, 4096);
    plant = std::make_unique<Plant>(
        dual_v(), emulator_plant_config(load_plant_config_file(config_file()), cfg));
    emu = std::make_unique<DriveEmulator>(hub->endpoint(1), *plant, cfg);
  }
  drivers::InProcessBus& master() { return hub->endpoint(0); }
  // Set the clock and let the emulator handle everything sent so far.
  void at(std::uint64_t t_ns) {
    hub->set_time_ns(t_ns);
    emu->poll(t_ns);
  }
  void now() { emu->poll(hub->now_ns()); }
  void send(const fw::Result<fw::CanFrame>& f) {
    ASSERT_TRUE(f.ok()) << fw::to_string(f.error());
    ASSERT_EQ(master().send(*f), drivers::BusStatus::kOk);
  }
  void send(const fw::CanFrame& f) { ASSERT_EQ(master().send(f), drivers::BusStatus::kOk); }
  // Every frame the master received (those only() set aside first), in order.
  std::vector<fw::CanFrame> drain() {
    std::vector<fw::CanFrame> out;
    out.swap(stash);
    fw::CanFrame f;
    while (master().receive(f) == drivers::BusStatus::kOk) out.push_back(f);
    return out;
  }
  // The frames with `id`; the others stay for the next drain()/only().
  std::vector<fw::CanFrame> only(std::uint32_t id) {
    std::vector<fw::CanFrame> out, rest;
    for (const fw::CanFrame& f : drain()) (f.id == id ? out : rest).push_back(f);
    stash = rest;
    return out;
  }
  // Power-on: the boot-up frames.
  std::vector<fw::CanFrame> power_on() {
    at(0);
    return drain();
  }
  // One SDO request to `node`, handled now; the response (or an empty frame).
  fw::CanFrame sdo(std::uint8_t node, const fw::Result<fw::CanFrame>& request) {
    send(request);
    now();
    const std::vector<fw::CanFrame> r = only(fw::cob_id(fw::Function::kSdoTx, node));
    EXPECT_EQ(r.size(), 1u);
    return r.empty() ? fw::CanFrame{} : r.front();
  }
  void write(std::uint8_t node, const fw::OdEntry& e, std::uint32_t v) {
    const fw::CanFrame r = sdo(node, fw::sdo_download_value(node, e, v));
    EXPECT_EQ(r.data[0], 0x60) << "writing " << std::hex << e.index << " sub " << int(e.subindex)
                               << ": abort " << fw::get_u32_le(&r.data[4]) << " "
                               << fw::sdo_abort_text(fw::get_u32_le(&r.data[4]));
  }
  void write_all(const fw::OdEntry& e, std::uint32_t v) {
    for (const auto& d : cfg.drives) write(d.node_id, e, v);
  }
  std::uint32_t read(std::uint8_t node, const fw::OdEntry& e) {
    const fw::CanFrame r = sdo(node, fw::sdo_upload_initiate(node, e.index, e.subindex));
    EXPECT_EQ(r.data[0] & 0xE0, 0x40) << "abort " << std::hex << fw::get_u32_le(&r.data[4]);
    return fw::get_u32_le(&r.data[4]);
  }
  // The SDO abort code of a response, 0 if it is not an abort.
  static std::uint32_t abort_code(const fw::CanFrame& r) {
    return r.data[0] == 0x80 ? fw::get_u32_le(&r.data[4]) : 0;
  }
  // One control cycle: RPDO1 (controlword, torque) to every drive, then SYNC; handled at
  // the current time, which then advances by the SYNC period.
  void cycle(std::uint16_t cw, std::int16_t torque, bool rpdo = true) {
    if (rpdo)
      for (const auto& d : cfg.drives) send(fw::encode_rpdo1(d.node_id, {cw, torque}));
    send(fw::encode_sync());
    now();
    hub->advance_ns(cfg.sync_period_ns);
  }
  // Boot, mode 10, NMT start, Operation enabled through 2-3-4 with RPDOs.
  void to_operation_enabled() {
    power_on();
    write_all(fw::od::kModesOfOperation, 10);
    send(fw::encode_nmt(fw::NmtCommand::kStart, 0));
    now();
    cycle(0x06, 0);
    cycle(0x07, 0);
    cycle(0x0F, 0);
    drain();
    for (int i = 0; i < emu->size(); ++i)
      ASSERT_EQ(emu->status(i).state, fw::Cia402State::kOperationEnabled) << "drive " << i;
  }

  DriveEmulatorConfig cfg;
  std::vector<fw::CanFrame> stash;
  std::unique_ptr<drivers::InProcessHub> hub;
  std::unique_ptr<Plant> plant;
  std::unique_ptr<DriveEmulator> emu;
};

}  // namespace dualv::sim::test
