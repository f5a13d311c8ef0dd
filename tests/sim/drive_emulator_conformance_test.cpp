// The drive emulator against a scripted master, frames in and frames out, for what issue 13
// found missing: sub-index 0 on every record (CiA 301 7.4.3), EMCY carrying the error
// register and followed by the error reset 0000h (CiA 301 7.2.7), the simulated time taken
// from the SYNCs received (1006h only monitors them), a fault whose cause remains refusing
// transition 15 (CiA 402-2 6.2), and the foreign-drive options (uploads without size,
// objects left out). Expected frames are written by hand from the standards.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <string>
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

// ---- NMT (CiA 301 7.2.8.3.1: 000h, DLC 2, command specifier + node, 0 = all) -----------

struct NmtCase {
  const char* name;
  std::vector<std::uint8_t> frame;      // the NMT frame's data bytes (DLC = size)
  std::array<EmulatedNmt, 4> after;     // from every node Pre-operational
  std::vector<std::uint16_t> boot_ups;  // 700h + id frames with 00h sent in answer
};

class EmulatorNmt : public EmulatorTest, public ::testing::WithParamInterface<NmtCase> {};

TEST_P(EmulatorNmt, CommandAsTheStandardSays) {
  const NmtCase& c = GetParam();
  power_on();
  fw::CanFrame f;
  f.id = 0x000;
  f.dlc = static_cast<std::uint8_t>(c.frame.size());
  std::copy(c.frame.begin(), c.frame.end(), f.data.begin());
  send(f);
  now();
  std::vector<std::uint16_t> boot_ups;
  for (const fw::CanFrame& r : drain())
    if (r.id >= 0x701 && r.id <= 0x704 && r.dlc == 1 && r.data[0] == 0x00)
      boot_ups.push_back(static_cast<std::uint16_t>(r.id));
  EXPECT_EQ(boot_ups, c.boot_ups);
  for (int i = 0; i < 4; ++i)
    EXPECT_EQ(emu->status(i).nmt, c.after[static_cast<std::size_t>(i)]) << "node " << i + 1;
}

constexpr EmulatedNmt P = EmulatedNmt::kPreOperational;
constexpr EmulatedNmt O = EmulatedNmt::kOperational;
constexpr EmulatedNmt S = EmulatedNmt::kStopped;

INSTANTIATE_TEST_SUITE_P(
    Cia301, EmulatorNmt,
    ::testing::Values(
        NmtCase{"StartAll", {0x01, 0x00}, {O, O, O, O}, {}},
        NmtCase{"StartNode2", {0x01, 0x02}, {P, O, P, P}, {}},
        NmtCase{"StopAll", {0x02, 0x00}, {S, S, S, S}, {}},
        NmtCase{"StopNode4", {0x02, 0x04}, {P, P, P, S}, {}},
        NmtCase{"PreOperationalNode3", {0x80, 0x03}, {P, P, P, P}, {}},
        NmtCase{"ResetNode1", {0x81, 0x01}, {P, P, P, P}, {0x701}},
        NmtCase{"ResetCommunicationAll", {0x82, 0x00}, {P, P, P, P}, {0x701, 0x702, 0x703, 0x704}},
        // Invalid: unknown command specifier, a node not on the bus, a node id above 127, a
        // frame of the wrong length: ignored, nothing changes.
        NmtCase{"UnknownCommandIgnored", {0x03, 0x00}, {P, P, P, P}, {}},
        NmtCase{"OtherNodeIgnored", {0x01, 0x05}, {P, P, P, P}, {}},
        NmtCase{"NodeAbove127Ignored", {0x01, 0x80}, {P, P, P, P}, {}},
        NmtCase{"ShortFrameIgnored", {0x01}, {P, P, P, P}, {}},
        NmtCase{"LongFrameIgnored", {0x01, 0x00, 0x00}, {P, P, P, P}, {}}),
    [](const ::testing::TestParamInfo<NmtCase>& i) { return i.param.name; });

TEST_F(EmulatorTest, StoppedNodeAnswersNoSdoAndResetNodeRestoresIt) {
  power_on();
  send(fw::encode_nmt(fw::NmtCommand::kStop, 1));
  now();
  drain();
  send(fw::sdo_upload_initiate(1, 0x1000, 0));
  now();
  EXPECT_TRUE(only(0x581).empty());  // SDO only in Pre-operational and Operational
  send(fw::encode_nmt(fw::NmtCommand::kResetNode, 1));
  now();
  EXPECT_EQ(only(0x701), (std::vector<fw::CanFrame>{frame(0x701, {0x00})}));
  EXPECT_EQ(read(1, od::kDeviceType) & 0xFFFF, 402u);
}

// ---- PDO mapping with dummy entries (CiA 301 7.4.7.1: index 0002h..0007h = the static
// data type, length its size) --------------------------------------------------------------

struct DummyCase {
  fw::DataType type;
  std::uint8_t bits;
};

class EmulatorDummy : public EmulatorTest, public ::testing::WithParamInterface<DummyCase> {};

TEST_P(EmulatorDummy, RpdoDummySkipsItsBytes) {
  const DummyCase& c = GetParam();
  power_on();
  const auto rx = od::PdoDirection::kRpdo;
  // RPDO2 of node 1 = [dummy of the type, 6071h target torque], acting on reception.
  write(1, od::pdo_mapping_count(rx, 2), 0);
  // Wrong length for the type: refused when the count is written (06040041h).
  write(1, od::pdo_mapping_entry(rx, 2, 1),
        (static_cast<std::uint32_t>(c.type) << 16) | static_cast<std::uint32_t>(c.bits + 8));
  write(1, od::pdo_mapping_entry(rx, 2, 2), fw::encode_mapping(fw::map_entry(od::kTargetTorque)));
  EXPECT_EQ(abort_code(sdo(1, fw::sdo_download_value(1, od::pdo_mapping_count(rx, 2), 2))),
            0x06040041u);
  // The right length: accepted.
  write(1, od::pdo_mapping_entry(rx, 2, 1), (static_cast<std::uint32_t>(c.type) << 16) | c.bits);
  write(1, od::pdo_mapping_count(rx, 2), 2);
  write(1, od::pdo_transmission_type(rx, 2), fw::kTransmissionEventProfile);
  write(1, od::pdo_cob_id(rx, 2), fw::pdo_cob_id_value(0x301, true));
  send(fw::encode_nmt(fw::NmtCommand::kStart, 1));
  now();
  // The frame: dummy bytes 0xAA (ignored), then the torque 1234 = 04D2h LE.
  fw::CanFrame f;
  f.id = 0x301;
  const std::size_t dummy_bytes = c.bits / 8;
  f.dlc = static_cast<std::uint8_t>(dummy_bytes + 2);
  for (std::size_t k = 0; k < dummy_bytes; ++k) f.data[k] = 0xAA;
  f.data[dummy_bytes] = 0xD2;
  f.data[dummy_bytes + 1] = 0x04;
  send(f);
  now();
  EXPECT_EQ(emu->status(0).target_torque, 1234);
  EXPECT_EQ(emu->status(0).counters.rpdos, 1u);
  // A dummy in a TPDO is refused (06040041h): dummies only in RPDOs.
  const auto tx = od::PdoDirection::kTpdo;
  write(1, od::pdo_cob_id(tx, 3), fw::pdo_cob_id_value(0x381, false));
  write(1, od::pdo_mapping_count(tx, 3), 0);
  write(1, od::pdo_mapping_entry(tx, 3, 1), (static_cast<std::uint32_t>(c.type) << 16) | c.bits);
  EXPECT_EQ(abort_code(sdo(1, fw::sdo_download_value(1, od::pdo_mapping_count(tx, 3), 1))),
            0x06040041u);
}

INSTANTIATE_TEST_SUITE_P(Cia301, EmulatorDummy,
                         ::testing::Values(DummyCase{fw::DataType::kInteger8, 8},
                                           DummyCase{fw::DataType::kInteger16, 16},
                                           DummyCase{fw::DataType::kInteger32, 32},
                                           DummyCase{fw::DataType::kUnsigned8, 8},
                                           DummyCase{fw::DataType::kUnsigned16, 16},
                                           DummyCase{fw::DataType::kUnsigned32, 32}),
                         [](const ::testing::TestParamInfo<DummyCase>& i) {
                           return "Dummy000" + std::to_string(static_cast<int>(i.param.type));
                         });

// ---- heartbeat consumer timing (CiA 301 7.2.8.3.2.2): at T - 1 nothing, at T the event --

TEST_F(EmulatorTest, HeartbeatConsumerAtTMinusOneAndT) {
  DriveEmulatorConfig c = default_config();
  c.rpdo_watchdog_cycles = 0;  // no SYNC in this test: only the heartbeat consumer acts
  c.free_run_after_ns = 0;
  build(c);
  to_operation_enabled();
  write_all(od::consumer_heartbeat(1), fw::consumer_heartbeat_value(127, 100));
  const std::uint64_t t0 = hub->now_ns();
  send(fw::encode_heartbeat(127, fw::NmtState::kOperational));
  at(t0);
  drain();
  at(t0 + 100 * kMs - 1);
  EXPECT_TRUE(only(0x081).empty());
  EXPECT_FALSE(emu->status(0).heartbeat_lost);
  at(t0 + 100 * kMs);
  EXPECT_TRUE(emu->status(0).heartbeat_lost);
  // 8130h with 1001h = generic + communication (11h); then the 6007h reaction (quick stop).
  EXPECT_EQ(only(0x081),
            (std::vector<fw::CanFrame>{frame(0x081, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0})}));
  // The heartbeat back: EMCY 0000h with what remains in 1001h (nothing).
  send(fw::encode_heartbeat(127, fw::NmtState::kOperational));
  at(t0 + 101 * kMs);
  EXPECT_EQ(only(0x081), (std::vector<fw::CanFrame>{frame(0x081, {0, 0, 0, 0, 0, 0, 0, 0})}));
}

}  // namespace
}  // namespace dualv::sim::test
