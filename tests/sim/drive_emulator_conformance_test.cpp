// The drive emulator against a scripted master, frames in and frames out, for what issue 13
// found missing: sub-index 0 on every record (CiA 301 7.4.3), EMCY carrying the error
// register and followed by the error reset 0000h (CiA 301 7.2.7), the simulated time taken
// from the SYNCs received (1006h only monitors them), a fault whose cause remains refusing
// transition 15 (CiA 402-2 6.2), and the foreign-drive options (uploads without size,
// objects left out). Expected frames are written by hand from the standards.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "tests/sim/emulator_fixture.hpp"

namespace dualv::sim::test {
namespace {

namespace od = fw::od;

// The records of the emulated drive and what their sub0 must say: the highest sub-index
// supported (communication records, identity, 608Fh, 60C2h, 1016h).
struct RecordCase {
  std::uint16_t index;
  std::uint8_t highest;
};
const RecordCase kRecords[] = {
    {0x1016, 2}, {0x1018, 4}, {0x1400, 5}, {0x1401, 5}, {0x1402, 5}, {0x1403, 5},
    {0x1800, 5}, {0x1801, 5}, {0x1802, 5}, {0x1803, 5}, {0x608F, 2}, {0x60C2, 2},
};

TEST_F(EmulatorTest, EveryRecordHasSubindexZero) {
  power_on();
  for (const RecordCase& r : kRecords) {
    // CiA 301 7.2.4.3.6: 4Fh = expedited, 1 byte; sub0 is UNSIGNED8.
    const fw::CanFrame resp = sdo(1, fw::sdo_upload_initiate(1, r.index, 0));
    EXPECT_EQ(resp.data[0], 0x4F) << std::hex << r.index << " abort " << abort_code(resp);
    EXPECT_EQ(resp.data[4], r.highest) << std::hex << r.index;
    // The sub-index it names exists, the one after it does not (06090011h).
    std::uint32_t raw = 0;
    EXPECT_TRUE(emu->read_object(0, r.index, r.highest, raw)) << std::hex << r.index;
    EXPECT_EQ(abort_code(sdo(1, fw::sdo_upload_initiate(1, r.index,
                                                        static_cast<std::uint8_t>(r.highest + 1)))),
              0x06090011u)
        << std::hex << r.index;
    // Read-only: a write of sub0 is refused with 06010002h.
    EXPECT_EQ(
        abort_code(sdo(1, fw::sdo_download_expedited(1, r.index, 0, std::vector<std::uint8_t>{1}))),
        0x06010002u)
        << std::hex << r.index;
  }
  // Golden: 1018h sub0 -> 581#4F 18 10 00 04 00 00 00.
  EXPECT_EQ(sdo(1, fw::sdo_upload_initiate(1, 0x1018, 0)),
            frame(0x581, {0x4F, 0x18, 0x10, 0x00, 0x04, 0, 0, 0}));
  // Mapping records: sub0 = number of mapped objects (RPDO1 = 2, TPDO1 = 2, others 0).
  EXPECT_EQ(read(1, od::pdo_mapping_count(od::PdoDirection::kRpdo, 1)), 2u);
  EXPECT_EQ(read(1, od::pdo_mapping_count(od::PdoDirection::kTpdo, 1)), 2u);
  EXPECT_EQ(read(1, od::pdo_mapping_count(od::PdoDirection::kRpdo, 3)), 0u);
}

// ---- EMCY (CiA 301 7.2.7.3.1: code LE, error register 1001h, 5 bytes manufacturer) ------

TEST_F(EmulatorTest, PdoLengthErrorCarriesTheErrorRegisterAndIsReset) {
  to_operation_enabled();
  // RPDO1 of node 1 with 2 bytes instead of 4.
  send(frame(0x201, {0x0F, 0x00}));
  now();
  // 8210h, 1001h = generic (bit 0) + communication (bit 4) = 11h.
  EXPECT_EQ(only(0x081),
            (std::vector<fw::CanFrame>{frame(0x081, {0x10, 0x82, 0x11, 0, 0, 0, 0, 0})}));
  EXPECT_EQ(read(1, od::kErrorRegister), 0x11u);
  // Still short: no second EMCY for the same condition.
  send(frame(0x201, {0x0F, 0x00}));
  now();
  EXPECT_TRUE(only(0x081).empty());
  // A correct RPDO: the condition is gone -> EMCY 0000h with 1001h = 00h.
  send(fw::encode_rpdo1(1, {0x0F, 0}));
  now();
  EXPECT_EQ(only(0x081), (std::vector<fw::CanFrame>{frame(0x081, {0, 0, 0, 0, 0, 0, 0, 0})}));
  EXPECT_EQ(read(1, od::kErrorRegister), 0x00u);
  EXPECT_EQ(emu->status(0).counters.rpdo_length_errors, 2u);
}

TEST_F(EmulatorTest, ErrorResetCarriesTheErrorsThatRemain) {
  to_operation_enabled();
  emu->inject_fault(0, fw::emcy::kDeviceOverTemperature);  // 4210h: generic + temperature
  EXPECT_EQ(only(0x081),
            (std::vector<fw::CanFrame>{frame(0x081, {0x10, 0x42, 0x09, 0, 0, 0, 0, 0})}));
  send(frame(0x201, {0x00}));  // short RPDO while in Fault: 8210h, register 09h | 11h
  now();
  EXPECT_EQ(only(0x081),
            (std::vector<fw::CanFrame>{frame(0x081, {0x10, 0x82, 0x19, 0, 0, 0, 0, 0})}));
  send(fw::encode_rpdo1(1, {0x00, 0}));  // the length error is gone, the fault remains
  now();
  EXPECT_EQ(only(0x081), (std::vector<fw::CanFrame>{frame(0x081, {0, 0, 0x09, 0, 0, 0, 0, 0})}));
}

// ---- fault reset while the cause remains (CiA 402-2 transition 15) -----------------------

TEST_F(EmulatorTest, FaultResetRefusedWhileTheCauseRemains) {
  power_on();
  emu->hold_fault(0, fw::emcy::kDeviceOverTemperature);
  EXPECT_EQ(only(0x081),
            (std::vector<fw::CanFrame>{frame(0x081, {0x10, 0x42, 0x09, 0, 0, 0, 0, 0})}));
  write(1, od::kControlword, 0x00);
  write(1, od::kControlword, 0x80);  // rising edge of bit 7
  EXPECT_EQ(emu->status(0).state, fw::Cia402State::kFault);
  EXPECT_TRUE(only(0x081).empty());  // no error reset
  EXPECT_EQ(emu->status(0).counters.fault_resets_refused, 1u);
  EXPECT_EQ(read(1, od::kStatusword) & 0x4F, 0x08u);  // Fault pattern xxxx xxxx x0xx 1000
  emu->release_fault(0);
  write(1, od::kControlword, 0x80);  // no edge: nothing
  EXPECT_EQ(emu->status(0).state, fw::Cia402State::kFault);
  write(1, od::kControlword, 0x00);
  write(1, od::kControlword, 0x80);
  EXPECT_EQ(emu->status(0).state, fw::Cia402State::kSwitchOnDisabled);
  EXPECT_EQ(emu->status(0).last_transition, 15);
  EXPECT_EQ(only(0x081), (std::vector<fw::CanFrame>{frame(0x081, {0, 0, 0, 0, 0, 0, 0, 0})}));
  // Nothing enables by itself.
  cycle(0x80, 0);
  EXPECT_EQ(emu->status(0).state, fw::Cia402State::kSwitchOnDisabled);
}

// ---- time from the SYNCs, 1006h for monitoring only -------------------------------------

TEST_F(EmulatorTest, PlantTimeFollowsTheSyncSpacingNot1006h) {
  power_on();
  write_all(od::kCommunicationCyclePeriod, 2000);  // the master says 2 ms ...
  send(fw::encode_nmt(fw::NmtCommand::kStart, 0));
  now();
  // ... but sends SYNCs 1 ms apart, then one 4 ms later.
  const std::uint64_t t0 = hub->now_ns();
  const std::uint64_t at_ms[] = {0, 1, 2, 3, 7};
  std::vector<double> plant_times;
  for (std::uint64_t ms : at_ms) {
    at(t0 + ms * kMs);
    send(fw::encode_sync());
    now();
    plant_times.push_back(plant->output().time);
  }
  // Plant time starts at the first SYNC; each later one advances it by the real spacing.
  EXPECT_NEAR(plant_times[1] - plant_times[0], 0.001, 1e-12);
  EXPECT_NEAR(plant_times[2] - plant_times[1], 0.001, 1e-12);
  EXPECT_NEAR(plant_times[3] - plant_times[2], 0.001, 1e-12);
  EXPECT_NEAR(plant_times[4] - plant_times[3], 0.004, 1e-12);
  // 1006h = 2 ms: only the 4 ms gap is late (> 1.5 x 1006h = 3 ms).
  EXPECT_EQ(emu->late_syncs(), 1u);
}

TEST_F(EmulatorTest, NoSyncMonitoringWithout1006h) {
  power_on();
  write_all(od::kCommunicationCyclePeriod, 0);
  send(fw::encode_nmt(fw::NmtCommand::kStart, 0));
  now();
  for (std::uint64_t ms : {0, 5, 20}) {
    at(hub->now_ns() + ms * kMs);
    send(fw::encode_sync());
    now();
  }
  EXPECT_EQ(emu->late_syncs(), 0u);
}

// ---- a foreign drive's habits -----------------------------------------------------------

TEST_F(EmulatorTest, ForeignDriveAnswersUploadsWithoutSize) {
  DriveEmulatorConfig c = default_config();
  c.upload_without_size = true;
  c.producer_heartbeat_ms = 50;
  build(c);
  power_on();
  // CiA 301 7.2.4.3.6, e=1 s=0: 42h, four data bytes (1017h = 50 = 32h, padded).
  EXPECT_EQ(sdo(1, fw::sdo_upload_initiate(1, 0x1017, 0)),
            frame(0x581, {0x42, 0x17, 0x10, 0x00, 0x32, 0, 0, 0}));
}

TEST_F(EmulatorTest, ForeignDriveWithoutAnObject) {
  DriveEmulatorConfig c = default_config();
  c.absent_objects = {0x60C2};
  build(c);
  power_on();
  EXPECT_EQ(abort_code(sdo(1, fw::sdo_upload_initiate(1, 0x60C2, 1))), 0x06020000u);
  EXPECT_EQ(
      abort_code(sdo(1, fw::sdo_download_expedited(1, 0x60C2, 1, std::vector<std::uint8_t>{1}))),
      0x06020000u);
}

TEST(DriveEmulatorConfig, OnlyOptionalObjectsCanBeLeftOut) {
  DriveEmulatorConfig c = emulator_config_from(drivers::default_can_config());
  c.absent_objects = {0x6040};
  try {
    c.validate(4);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("object 6040h cannot be left out"), std::string::npos)
        << e.what();
  }
  c.absent_objects = {0x60C2, 0x1006, 0x6007};
  EXPECT_NO_THROW(c.validate(4));
}

}  // namespace
}  // namespace dualv::sim::test
