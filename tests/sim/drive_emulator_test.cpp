// The drive emulator against golden frames (bytes written from CiA 301 / CiA 402), with
// simulated time on an InProcessHub: NMT, SDO server, PDO mapping, CiA 402, torque path,
// heartbeats, watchdogs, EMCY, e-stop input, fault injection, no allocation.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "tests/sim/emulator_fixture.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::sim {
namespace {

using fw::Cia402State;
using test::EmulatorTest;
using test::frame;
using test::kMs;
namespace od = fw::od;

// ---- configuration ---------------------------------------------------------------------

TEST(DriveEmulatorConfig, FromCanSectionOfTheShippedFile) {
  const DriveEmulatorConfig c =
      emulator_config_from(drivers::load_can_config_file(test::config_file()));
  ASSERT_EQ(c.drives.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(c.drives[i].node_id, i + 1);
    EXPECT_EQ(c.drives[i].rated_torque_mnm, 50'000u);
    EXPECT_EQ(c.drives[i].max_torque_per_mille, 1200u);  // 60 N m of 50 N m
    EXPECT_EQ(c.drives[i].counts_per_revolution, 1u << 20);
  }
  EXPECT_EQ(c.sync_period_ns, 1'000'000u);
}

TEST(DriveEmulatorConfig, PlantConfigHandsDelayAndQuantisationToTheWire) {
  PlantConfig p = load_plant_config_file(test::config_file());
  ASSERT_TRUE(p.transport_delay.enabled);
  ASSERT_EQ(p.transport_delay.cycles, 1);
  DriveEmulatorConfig e = emulator_config_from(drivers::default_can_config());
  PlantConfig q = emulator_plant_config(p, e);
  EXPECT_FALSE(q.torque_quantisation.enabled);
  EXPECT_FALSE(q.transport_delay.enabled);  // the bus gives the one cycle
  p.transport_delay.cycles = 3;
  EXPECT_EQ(emulator_plant_config(p, e).transport_delay.cycles, 2);
  e.drives[2].counts_per_revolution = 4096;
  EXPECT_THROW(emulator_plant_config(p, e), std::invalid_argument);
}

TEST(DriveEmulatorConfig, SetUpErrorsSayWhatToFix) {
  Plant plant(test::dual_v(), PlantConfig::ideal());
  drivers::InProcessHub hub(2);
  DriveEmulatorConfig c = emulator_config_from(drivers::default_can_config());
  c.drives.pop_back();
  try {
    DriveEmulator e(hub.endpoint(1), plant, c);
    FAIL() << "3 drives for 4 joints accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("3 drives for a plant of 4 joints"), std::string::npos)
        << e.what();
  }
  c = emulator_config_from(drivers::default_can_config());
  c.drives[3].node_id = 1;
  EXPECT_THROW(DriveEmulator(hub.endpoint(1), plant, c), std::invalid_argument);
}

// ---- NMT -------------------------------------------------------------------------------

TEST_F(EmulatorTest, BootUpAtPowerOnAndAfterNmtReset) {
  // CiA 301 7.2.8.3.2.2: boot-up = 700h + node, one byte 00h.
  EXPECT_EQ(power_on(), (std::vector<fw::CanFrame>{frame(0x701, {0x00}), frame(0x702, {0x00}),
                                                   frame(0x703, {0x00}), frame(0x704, {0x00})}));
  for (int i = 0; i < 4; ++i) EXPECT_EQ(emu->status(i).nmt, EmulatedNmt::kPreOperational);
  send(frame(0x000, {0x81, 0x03}));  // reset node 3
  now();
  EXPECT_EQ(drain(), (std::vector<fw::CanFrame>{frame(0x703, {0x00})}));
  send(frame(0x000, {0x82, 0x00}));  // reset communication, all nodes
  now();
  EXPECT_EQ(drain().size(), 4u);
}

TEST_F(EmulatorTest, NmtStatesGateSdoAndPdos) {
  power_on();
  // Pre-operational: SYNC gives no TPDO.
  send(fw::encode_sync());
  now();
  EXPECT_TRUE(only(0x181).empty());
  send(frame(0x000, {0x01, 0x01}));  // start node 1
  now();
  send(fw::encode_sync());
  now();
  EXPECT_EQ(only(0x181).size(), 1u);
  EXPECT_EQ(emu->status(0).nmt, EmulatedNmt::kOperational);
  EXPECT_EQ(emu->status(1).nmt, EmulatedNmt::kPreOperational);
  send(frame(0x000, {0x02, 0x01}));  // stop node 1: no SDO answer in Stopped
  now();
  send(fw::sdo_upload_initiate(1, 0x6041, 0));
  now();
  EXPECT_TRUE(drain().empty());
  EXPECT_EQ(emu->status(0).nmt, EmulatedNmt::kStopped);
}

TEST_F(EmulatorTest, ResetNodeRestoresTheDictionary) {
  power_on();
  write(1, od::kProducerHeartbeat, 100);
  EXPECT_EQ(read(1, od::kProducerHeartbeat), 100u);
  send(fw::encode_nmt(fw::NmtCommand::kResetNode, 1));
  now();
  drain();
  EXPECT_EQ(read(1, od::kProducerHeartbeat), 0u);
}

// ---- SDO server --------------------------------------------------------------------------

TEST_F(EmulatorTest, SdoExpeditedUploadGolden) {
  power_on();
  // 6041h in Switch on disabled: 0040h + remote (bit 9) = 0240h; 4Bh = 2 bytes, expedited.
  send(frame(0x601, {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}));
  now();
  EXPECT_EQ(drain(),
            (std::vector<fw::CanFrame>{frame(0x581, {0x4B, 0x41, 0x60, 0x00, 0x40, 0x02, 0, 0})}));
  // 1000h: 4 bytes (43h), CiA 402 device.
  send(frame(0x602, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}));
  now();
  EXPECT_EQ(
      drain(),
      (std::vector<fw::CanFrame>{frame(0x582, {0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0})}));
}

TEST_F(EmulatorTest, SdoExpeditedDownloadGolden) {
  power_on();
  send(frame(0x601, {0x2B, 0x17, 0x10, 0x00, 0x64, 0x00, 0, 0}));  // 1017h = 100 ms
  now();
  EXPECT_EQ(drain(),
            (std::vector<fw::CanFrame>{frame(0x581, {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0})}));
  EXPECT_EQ(read(1, od::kProducerHeartbeat), 100u);
  // e = 1, s = 0: size not indicated, the object's own size is taken.
  send(frame(0x601, {0x22, 0x17, 0x10, 0x00, 0xC8, 0x00, 0, 0}));
  now();
  EXPECT_EQ(drain().front().data[0], 0x60);
  EXPECT_EQ(read(1, od::kProducerHeartbeat), 200u);
}

TEST_F(EmulatorTest, SdoAbortsGolden) {
  power_on();
  struct Case {
    std::vector<std::uint8_t> request;
    fw::CanFrame response;
  };
  const Case cases[] = {
      // unknown object 2000h -> 06020000h
      {{0x40, 0x00, 0x20, 0x00, 0, 0, 0, 0},
       frame(0x581, {0x80, 0x00, 0x20, 0x00, 0x00, 0x00, 0x02, 0x06})},
      // 1018h sub 9 -> 06090011h
      {{0x40, 0x18, 0x10, 0x09, 0, 0, 0, 0},
       frame(0x581, {0x80, 0x18, 0x10, 0x09, 0x11, 0x00, 0x09, 0x06})},
      // write 6041h (read-only) -> 06010002h
      {{0x2B, 0x41, 0x60, 0x00, 0x06, 0x00, 0, 0},
       frame(0x581, {0x80, 0x41, 0x60, 0x00, 0x02, 0x00, 0x01, 0x06})},
      // 6040h (u16) written with 4 bytes -> 06070012h
      {{0x23, 0x40, 0x60, 0x00, 0x06, 0x00, 0, 0},
       frame(0x581, {0x80, 0x40, 0x60, 0x00, 0x12, 0x00, 0x07, 0x06})},
      // 1017h (u16) written with 1 byte -> 06070013h
      {{0x2F, 0x17, 0x10, 0x00, 0x06, 0, 0, 0},
       frame(0x581, {0x80, 0x17, 0x10, 0x00, 0x13, 0x00, 0x07, 0x06})},
      // 6060h = 3 (profile velocity, not supported) -> 06090030h
      {{0x2F, 0x60, 0x60, 0x00, 0x03, 0, 0, 0},
       frame(0x581, {0x80, 0x60, 0x60, 0x00, 0x30, 0x00, 0x09, 0x06})},
      // 6007h = 7 -> 06090031h (value too high)
      {{0x2B, 0x07, 0x60, 0x00, 0x07, 0x00, 0, 0},
       frame(0x581, {0x80, 0x07, 0x60, 0x00, 0x31, 0x00, 0x09, 0x06})},
      // ccs 7: not a command -> 05040001h
      {{0xE0, 0x41, 0x60, 0x00, 0, 0, 0, 0},
       frame(0x581, {0x80, 0x41, 0x60, 0x00, 0x01, 0x00, 0x04, 0x05})},
      // upload segment without a transfer -> 05040001h
      {{0x60, 0, 0, 0, 0, 0, 0, 0}, frame(0x581, {0x80, 0x00, 0x00, 0x00, 0x01, 0x00, 0x04, 0x05})},
  };
  for (const Case& c : cases) {
    fw::CanFrame req;
    req.id = 0x601;
    req.dlc = 8;
    std::copy(c.request.begin(), c.request.end(), req.data.begin());
    send(req);
    now();
    EXPECT_EQ(drain(), (std::vector<fw::CanFrame>{c.response}))
        << "request " << testing::PrintToString(req);
  }
  // A wrong DLC is not an SDO request: no answer.
  send(frame(0x601, {0x40, 0x41, 0x60, 0x00}));
  now();
  EXPECT_TRUE(drain().empty());
}

TEST_F(EmulatorTest, SdoSegmentedDownloadGolden) {
  power_on();
  // Initiate, size indicated (21h), 2 bytes announced for 1017h.
  send(frame(0x601, {0x21, 0x17, 0x10, 0x00, 0x02, 0x00, 0x00, 0x00}));
  now();
  EXPECT_EQ(drain(),
            (std::vector<fw::CanFrame>{frame(0x581, {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0})}));
  // Segment: t = 0, n = 5 unused bytes, c = 1 -> 0Bh; 012Ch = 300 ms.
  send(frame(0x601, {0x0B, 0x2C, 0x01, 0, 0, 0, 0, 0}));
  now();
  EXPECT_EQ(drain(), (std::vector<fw::CanFrame>{frame(0x581, {0x20, 0, 0, 0, 0, 0, 0, 0})}));
  EXPECT_EQ(read(1, od::kProducerHeartbeat), 300u);
  // Two segments of a 4-byte object (1016h sub1): toggles 0 then 1 (responses 20h, 30h).
  send(fw::sdo_download_initiate(1, 0x1016, 1, 4));
  now();
  drain();
  const std::uint8_t a[] = {0x32, 0x00};
  const std::uint8_t b[] = {0x7F, 0x00};
  send(fw::sdo_download_segment(1, false, a, false));
  now();
  EXPECT_EQ(drain().front(), frame(0x581, {0x20, 0, 0, 0, 0, 0, 0, 0}));
  send(fw::sdo_download_segment(1, true, b, true));
  now();
  EXPECT_EQ(drain().front(), frame(0x581, {0x30, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(read(1, od::consumer_heartbeat(1)), fw::consumer_heartbeat_value(127, 50));
}

TEST_F(EmulatorTest, SdoSegmentedDownloadAborts) {
  power_on();
  // Toggle not alternated -> 05030000h.
  send(fw::sdo_download_initiate(1, 0x1016, 1, 4));
  now();
  drain();
  const std::uint8_t two[] = {1, 2};
  send(fw::sdo_download_segment(1, true, two, false));
  now();
  EXPECT_EQ(
      drain(),
      (std::vector<fw::CanFrame>{frame(0x581, {0x80, 0x16, 0x10, 0x01, 0x00, 0x00, 0x03, 0x05})}));
  // Announced size differs from the object -> 06070012h at once.
  send(fw::sdo_download_initiate(1, 0x1017, 0, 4));
  now();
  EXPECT_EQ(abort_code(drain().front()), 0x06070012u);
  // Size not announced, 3 bytes for a 2-byte object -> 06070012h after the last segment.
  send(frame(0x601, {0x20, 0x17, 0x10, 0x00, 0, 0, 0, 0}));
  now();
  drain();
  const std::uint8_t three[] = {1, 2, 3};
  send(fw::sdo_download_segment(1, false, three, true));
  now();
  EXPECT_EQ(abort_code(drain().front()), 0x06070012u);
  EXPECT_EQ(read(1, od::kProducerHeartbeat), 0u);  // nothing written
}

TEST_F(EmulatorTest, SdoSegmentedUploadGolden) {
  DriveEmulatorConfig c = default_config();
  c.segmented_upload = true;
  build(c);
  power_on();
  // Initiate response: 41h (s = 1, e = 0) + size 2.
  send(frame(0x601, {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}));
  now();
  EXPECT_EQ(drain(),
            (std::vector<fw::CanFrame>{frame(0x581, {0x41, 0x41, 0x60, 0x00, 0x02, 0, 0, 0})}));
  // Segment request t = 0 (60h) -> 0Bh: t = 0, n = 5, c = 1, data 40h 02h.
  send(frame(0x601, {0x60, 0, 0, 0, 0, 0, 0, 0}));
  now();
  EXPECT_EQ(drain(), (std::vector<fw::CanFrame>{frame(0x581, {0x0B, 0x40, 0x02, 0, 0, 0, 0, 0})}));
  // Toggle wrong on the first segment (70h) -> 05030000h.
  send(frame(0x601, {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}));
  now();
  drain();
  send(frame(0x601, {0x70, 0, 0, 0, 0, 0, 0, 0}));
  now();
  EXPECT_EQ(abort_code(drain().front()), 0x05030000u);
}

// ---- PDO mapping ---------------------------------------------------------------------------

TEST_F(EmulatorTest, DefaultPdosAreTheContractLayouts) {
  to_operation_enabled();
  cycle(0x0F, 0);
  const std::vector<fw::CanFrame> t = only(0x181);
  ASSERT_EQ(t.size(), 1u);
  const fw::Result<fw::DriveFeedback> fb = fw::decode_tpdo1(t.front());
  ASSERT_TRUE(fb.ok());
  EXPECT_EQ(fb->statusword, 0x1237);  // OE 27h + voltage 10h + remote 200h + follows 1000h
  EXPECT_EQ(fb->position, plant->output().counts[0]);
}

TEST_F(EmulatorTest, MappingWrittenBySdoChangesTheTpdo) {
  power_on();
  const auto tx = od::PdoDirection::kTpdo;
  write(1, od::pdo_cob_id(tx, 1), fw::pdo_cob_id_value(0x181, false));
  write(1, od::pdo_mapping_count(tx, 1), 0);
  write(1, od::pdo_mapping_entry(tx, 1, 1), fw::encode_mapping(fw::map_entry(od::kStatusword)));
  write(1, od::pdo_mapping_entry(tx, 1, 2), fw::encode_mapping(fw::map_entry(od::kDigitalInputs)));
  write(1, od::pdo_mapping_count(tx, 1), 2);
  write(1, od::pdo_cob_id(tx, 1), fw::pdo_cob_id_value(0x181, true));
  send(fw::encode_nmt(fw::NmtCommand::kStart, 0));
  now();
  emu->press_estop(true);
  send(fw::encode_sync());
  now();
  // Statusword 0240h + warning (bit 7) = 02C0h; 60FDh bit 16 (the e-stop input).
  EXPECT_EQ(only(0x181),
            (std::vector<fw::CanFrame>{frame(0x181, {0xC0, 0x02, 0x00, 0x00, 0x01, 0x00})}));
  emu->press_estop(false);
  send(fw::encode_sync());
  now();
  EXPECT_EQ(only(0x181), (std::vector<fw::CanFrame>{frame(0x181, {0x40, 0x02, 0, 0, 0, 0})}));
}

TEST_F(EmulatorTest, MappingRulesAbort) {
  power_on();
  const auto tx = od::PdoDirection::kTpdo;
  const auto rx = od::PdoDirection::kRpdo;
  // TPDO1 still valid: its mapping cannot change (06010000h).
  EXPECT_EQ(abort_code(sdo(1, fw::sdo_download_value(1, od::pdo_mapping_count(tx, 1), 0))),
            0x06010000u);
  write(1, od::pdo_cob_id(tx, 1), fw::pdo_cob_id_value(0x181, false));
  // sub0 not 0: entries cannot change.
  EXPECT_EQ(abort_code(sdo(1, fw::sdo_download_value(1, od::pdo_mapping_entry(tx, 1, 1), 0))),
            0x06010000u);
  write(1, od::pdo_mapping_count(tx, 1), 0);
  // 1017h is not mappable (06040041h).
  write(1, od::pdo_mapping_entry(tx, 1, 1),
        fw::encode_mapping(fw::map_entry(od::kProducerHeartbeat)));
  EXPECT_EQ(abort_code(sdo(1, fw::sdo_download_value(1, od::pdo_mapping_count(tx, 1), 1))),
            0x06040041u);
  // Three 32-bit objects: 96 bits > 64 (06040042h).
  for (std::uint8_t s = 1; s <= 3; ++s)
    write(1, od::pdo_mapping_entry(tx, 1, s),
          fw::encode_mapping(fw::map_entry(od::kPositionActual)));
  EXPECT_EQ(abort_code(sdo(1, fw::sdo_download_value(1, od::pdo_mapping_count(tx, 1), 3))),
            0x06040042u);
  // A dummy in a TPDO (06040041h); an RPDO may carry one.
  write(1, od::pdo_mapping_entry(tx, 1, 1),
        fw::encode_mapping(fw::dummy_entry(fw::DataType::kInteger16)));
  EXPECT_EQ(abort_code(sdo(1, fw::sdo_download_value(1, od::pdo_mapping_count(tx, 1), 1))),
            0x06040041u);
  // The statusword (read-only) in an RPDO (06040041h).
  write(1, od::pdo_cob_id(rx, 1), fw::pdo_cob_id_value(0x201, false));
  write(1, od::pdo_mapping_count(rx, 1), 0);
  write(1, od::pdo_mapping_entry(rx, 1, 1), fw::encode_mapping(fw::map_entry(od::kStatusword)));
  EXPECT_EQ(abort_code(sdo(1, fw::sdo_download_value(1, od::pdo_mapping_count(rx, 1), 1))),
            0x06040041u);
  // Changing the COB-ID of a valid PDO (06090030h).
  write(1, od::pdo_cob_id(rx, 2), fw::pdo_cob_id_value(0x301, true));
  EXPECT_EQ(abort_code(sdo(1, fw::sdo_download_value(1, od::pdo_cob_id(rx, 2),
                                                     fw::pdo_cob_id_value(0x200, true)))),
            0x06090030u);
}

TEST_F(EmulatorTest, BroadcastLayoutCarriesEveryTorque) {
  power_on();
  const auto rx = od::PdoDirection::kRpdo;
  for (std::uint8_t slot = 0; slot < 4; ++slot) {
    const std::uint8_t node = static_cast<std::uint8_t>(slot + 1);
    // RPDO1: controlword alone, acting on reception (255).
    write(node, od::pdo_cob_id(rx, 1), fw::pdo_cob_id_value(0x200 + node, false));
    write(node, od::pdo_mapping_count(rx, 1), 0);
    write(node, od::pdo_mapping_entry(rx, 1, 1),
          fw::encode_mapping(fw::map_entry(od::kControlword)));
    write(node, od::pdo_mapping_count(rx, 1), 1);
    write(node, od::pdo_transmission_type(rx, 1), fw::kTransmissionEventProfile);
    write(node, od::pdo_cob_id(rx, 1), fw::pdo_cob_id_value(0x200 + node, true));
    // RPDO2: the broadcast frame on 200h, own slot + dummies, synchronous.
    const fw::PdoLayout l = fw::broadcast_rpdo_layout(slot, 4);
    write(node, od::pdo_mapping_count(rx, fw::kBroadcastRpdoNumber), 0);
    for (std::uint8_t s = 0; s < l.count; ++s)
      write(node, od::pdo_mapping_entry(rx, fw::kBroadcastRpdoNumber, s + 1),
            fw::encode_mapping(l.entries[s]));
    write(node, od::pdo_mapping_count(rx, fw::kBroadcastRpdoNumber), l.count);
    write(node, od::pdo_transmission_type(rx, fw::kBroadcastRpdoNumber), 1);
    write(node, od::pdo_cob_id(rx, fw::kBroadcastRpdoNumber),
          fw::pdo_cob_id_value(fw::kBroadcastRpdoCobId, true));
    write(node, od::kModesOfOperation, 10);
  }
  send(fw::encode_nmt(fw::NmtCommand::kStart, 0));
  now();
  for (const std::uint16_t cw : std::initializer_list<std::uint16_t>{0x06, 0x07, 0x0F})
    for (std::uint8_t node = 1; node <= 4; ++node) send(fw::encode_controlword_rpdo(node, cw));
  now();
  for (int i = 0; i < 4; ++i) EXPECT_EQ(emu->status(i).state, Cia402State::kOperationEnabled);
  fw::BroadcastTorques t;
  t.drives = 4;
  t.torque = {100, -200, 300, -400};
  send(fw::encode_broadcast_torques(t));
  send(fw::encode_sync());
  now();
  for (int i = 0; i < 4; ++i)
    EXPECT_DOUBLE_EQ(emu->status(i).torque_nm,
                     fw::per_mille_to_nm(t.torque[static_cast<std::size_t>(i)], 50.0));
}

TEST_F(EmulatorTest, StatuswordTpdoOnChangeBoundedByItsInhibitTime) {
  // Issue 15's feedback PDOs on node 1: TPDO1 = 6064h alone every SYNC, TPDO3 = 6041h on
  // change (255), inhibit time 50 x 100 us = 5 ms, event timer 20 ms.
  power_on();
  const auto tx = od::PdoDirection::kTpdo;
  write(1, od::pdo_cob_id(tx, 1), fw::pdo_cob_id_value(0x181, false));
  write(1, od::pdo_mapping_count(tx, 1), 0);
  write(1, od::pdo_mapping_entry(tx, 1, 1), 0x60640020);
  write(1, od::pdo_mapping_count(tx, 1), 1);
  write(1, od::pdo_cob_id(tx, 1), fw::pdo_cob_id_value(0x181, true));
  write(1, od::pdo_cob_id(tx, 3), fw::pdo_cob_id_value(0x381, false));
  write(1, od::pdo_mapping_count(tx, 3), 0);
  write(1, od::pdo_mapping_entry(tx, 3, 1), 0x60410010);
  write(1, od::pdo_mapping_count(tx, 3), 1);
  write(1, od::pdo_transmission_type(tx, 3), 0xFF);
  write(1, od::pdo_inhibit_time(tx, 3), 50);
  write(1, od::pdo_event_timer(tx, 3), 20);
  write(1, od::pdo_cob_id(tx, 3), fw::pdo_cob_id_value(0x381, true));
  write(1, od::kModesOfOperation, 10);
  drain();
  send(fw::encode_nmt(fw::NmtCommand::kStart, 1));
  at(0);
  // Started: the event timer is due at once: Switch on disabled + remote = 0240h.
  EXPECT_EQ(only(0x381), (std::vector<fw::CanFrame>{frame(0x381, {0x40, 0x02})}));
  // SYNC at 1 ms: the position (4 B), no statusword (unchanged).
  send(fw::encode_sync());
  at(1 * kMs);
  const auto pos = only(0x181);
  ASSERT_EQ(pos.size(), 1u);
  EXPECT_EQ(pos[0].dlc, 4);
  EXPECT_TRUE(only(0x381).empty());
  // Shutdown (0006h) at 2 ms: Ready to switch on = 0221h. The SYNC at 2 ms sees the change,
  // but the last TPDO3 went at 0 ms: held until 0 + 5 ms.
  write(1, od::kControlword, 0x06);
  for (std::uint64_t t : {2, 3, 4}) {
    send(fw::encode_sync());
    at(t * kMs);
    EXPECT_TRUE(only(0x381).empty()) << t << " ms";
  }
  at(5 * kMs - 1);
  EXPECT_TRUE(only(0x381).empty());
  at(5 * kMs);
  EXPECT_EQ(only(0x381), (std::vector<fw::CanFrame>{frame(0x381, {0x21, 0x02})}));
  // A change after the inhibit time is sent at the next SYNC: switch on (0007h) at 11 ms,
  // Switched on + voltage enabled = 0233h.
  at(11 * kMs);
  write(1, od::kControlword, 0x07);
  send(fw::encode_sync());
  at(11 * kMs);
  EXPECT_EQ(only(0x381), (std::vector<fw::CanFrame>{frame(0x381, {0x33, 0x02})}));
  // No change: the event timer sends it again 20 ms after the last one, not before.
  at(31 * kMs - 1);
  EXPECT_TRUE(only(0x381).empty());
  at(31 * kMs);
  EXPECT_EQ(only(0x381), (std::vector<fw::CanFrame>{frame(0x381, {0x33, 0x02})}));
}

TEST_F(EmulatorTest, DriveWithoutDummyMappingAbortsTheEntry) {
  DriveEmulatorConfig c = default_config();
  c.refuse_dummy_mapping = true;
  build(c);
  power_on();
  const auto rx = od::PdoDirection::kRpdo;
  write(1, od::pdo_cob_id(rx, 2), fw::pdo_cob_id_value(0x200, false));
  write(1, od::pdo_mapping_count(rx, 2), 0);
  write(1, od::pdo_mapping_entry(rx, 2, 1), 0x60710010);  // a real object: fine
  EXPECT_EQ(
      abort_code(sdo(1, fw::sdo_download_value(1, od::pdo_mapping_entry(rx, 2, 2), 0x00030010))),
      0x06040041u);
}

// ---- CiA 402 ------------------------------------------------------------------------------

TEST_F(EmulatorTest, EveryTransitionFromControlwords) {
  power_on();
  write(1, od::kModesOfOperation, 10);
  struct Step {
    std::uint16_t cw;
    Cia402State state;
    std::uint8_t transition;
  };
  auto run = [&](std::initializer_list<Step> steps) {
    for (const Step& s : steps) {
      write(1, od::kControlword, s.cw);
      EXPECT_EQ(emu->status(0).state, s.state) << "controlword " << std::hex << s.cw;
      EXPECT_EQ(emu->status(0).last_transition, s.transition) << "controlword " << std::hex << s.cw;
      // The statusword says the same (CiA 402-2 table 30).
      const auto decoded =
          fw::decode_statusword(static_cast<std::uint16_t>(read(1, od::kStatusword)));
      ASSERT_TRUE(decoded.ok());
      EXPECT_EQ(decoded->state, s.state);
    }
  };
  EXPECT_EQ(emu->status(0).last_transition, 1);  // 0, 1 on power-on
  run({{0x06, Cia402State::kReadyToSwitchOn, 2},
       {0x07, Cia402State::kSwitchedOn, 3},
       {0x0F, Cia402State::kOperationEnabled, 4},
       {0x07, Cia402State::kSwitchedOn, 5},
       {0x06, Cia402State::kReadyToSwitchOn, 6},
       {0x00, Cia402State::kSwitchOnDisabled, 7},
       {0x06, Cia402State::kReadyToSwitchOn, 2},
       {0x07, Cia402State::kSwitchedOn, 3},
       {0x0F, Cia402State::kOperationEnabled, 4},
       {0x06, Cia402State::kReadyToSwitchOn, 8},
       {0x07, Cia402State::kSwitchedOn, 3},
       {0x0F, Cia402State::kOperationEnabled, 4},
       {0x00, Cia402State::kSwitchOnDisabled, 9},
       {0x06, Cia402State::kReadyToSwitchOn, 2},
       {0x07, Cia402State::kSwitchedOn, 3},
       {0x01, Cia402State::kSwitchOnDisabled, 10},  // disable voltage (bit 1 clear)
       {0x06, Cia402State::kReadyToSwitchOn, 2},
       {0x07, Cia402State::kSwitchedOn, 3},
       {0x0F, Cia402State::kOperationEnabled, 4},
       {0x0B, Cia402State::kQuickStopActive, 11}});  // quick stop (bit 2 clear)
  // 605Ah = 2 (default): Switch on disabled once "stopped", at the next SYNC (12).
  send(fw::encode_sync());
  now();
  EXPECT_EQ(emu->status(0).state, Cia402State::kSwitchOnDisabled);
  EXPECT_EQ(emu->status(0).last_transition, 12);
  // 605Ah = 6 (stay): quick stop active until 12 by disable voltage or 16 by enable.
  write(1, od::kQuickStopOption, 6);
  run({{0x06, Cia402State::kReadyToSwitchOn, 2},
       {0x07, Cia402State::kSwitchedOn, 3},
       {0x0F, Cia402State::kOperationEnabled, 4},
       {0x0B, Cia402State::kQuickStopActive, 11},
       {0x0F, Cia402State::kOperationEnabled, 16},
       {0x0B, Cia402State::kQuickStopActive, 11},
       {0x00, Cia402State::kSwitchOnDisabled, 12}});
  // 605Ah = 0: disable drive function, straight to Switch on disabled.
  write(1, od::kQuickStopOption, 0);
  run({{0x06, Cia402State::kReadyToSwitchOn, 2},
       {0x07, Cia402State::kSwitchedOn, 3},
       {0x0F, Cia402State::kOperationEnabled, 4},
       {0x0B, Cia402State::kSwitchOnDisabled, 12}});
  // Fault (13, 14) and fault reset (15).
  emu->inject_fault(0, fw::emcy::kDeviceOverTemperature);
  EXPECT_EQ(emu->status(0).state, Cia402State::kFault);
  EXPECT_EQ(emu->status(0).last_transition, 14);
  run({{0x80, Cia402State::kSwitchOnDisabled, 15}});
}

TEST_F(EmulatorTest, FaultResetOnlyOnARisingEdge) {
  power_on();
  write(1, od::kControlword, 0x80);  // bit 7 already high
  emu->inject_fault(0, fw::emcy::kCurrent);
  write(1, od::kControlword, 0x80);  // still high: no edge
  EXPECT_EQ(emu->status(0).state, Cia402State::kFault);
  write(1, od::kControlword, 0x8F);  // high, other bits changing: still no edge
  EXPECT_EQ(emu->status(0).state, Cia402State::kFault);
  write(1, od::kControlword, 0x00);
  EXPECT_EQ(emu->status(0).state, Cia402State::kFault);
  write(1, od::kControlword, 0x80);  // 0 -> 1
  EXPECT_EQ(emu->status(0).state, Cia402State::kSwitchOnDisabled);
  EXPECT_EQ(emu->status(0).last_transition, 15);
  // Enable operation in Fault does nothing.
  emu->inject_fault(0, fw::emcy::kCurrent);
  write(1, od::kControlword, 0x0F);
  EXPECT_EQ(emu->status(0).state, Cia402State::kFault);
}

// ---- torque path -------------------------------------------------------------------------

TEST_F(EmulatorTest, TorqueOnlyInOperationEnabledAndPerMille) {
  power_on();
  write_all(od::kModesOfOperation, 10);
  send(fw::encode_nmt(fw::NmtCommand::kStart, 0));
  now();
  cycle(0x06, 123);  // Ready to switch on: no torque
  cycle(0x07, 123);  // Switched on: no torque
  for (int i = 0; i < 4; ++i) EXPECT_EQ(emu->status(i).torque_nm, 0.0);
  EXPECT_EQ(plant->output().tau_command.norm(), 0.0);
  cycle(0x0F, 123);  // Operation enabled, latched at this SYNC: 123 per mille of 50 N m
  for (int i = 0; i < 4; ++i) {
    EXPECT_DOUBLE_EQ(emu->status(i).torque_nm, 123 * 50.0 / 1000.0);
    EXPECT_DOUBLE_EQ(plant->output().tau_command[i], 123 * 50.0 / 1000.0);
  }
  // 6072h = 1200 per mille (60 N m) clips, statusword bit 11 set.
  cycle(0x0F, 2000);
  EXPECT_DOUBLE_EQ(emu->status(0).torque_nm, 60.0);
  EXPECT_NE(emu->status(0).statusword & fw::sw::kInternalLimitActive, 0);
  cycle(0x0F, -2000);
  EXPECT_DOUBLE_EQ(emu->status(0).torque_nm, -60.0);
  // Mode 0: Operation enabled but no CST: no torque, bit 12 clear.
  write(1, od::kModesOfOperation, 0);
  cycle(0x0F, 100);
  EXPECT_EQ(emu->status(0).torque_nm, 0.0);
  EXPECT_EQ(emu->status(0).statusword & fw::sw::kDriveFollowsCommand, 0);
  EXPECT_DOUBLE_EQ(emu->status(1).torque_nm, 5.0);
  // Leaving Operation enabled between SYNCs takes the torque off at once.
  write(2, od::kControlword, 0x07);
  EXPECT_EQ(emu->status(1).torque_nm, 0.0);
  EXPECT_EQ(plant->output().tau_command[1], 0.0);
}

TEST_F(EmulatorTest, TorqueActsFromTheLatchingSyncOnOneCycleOfTransportDelay) {
  to_operation_enabled();
  // RPDO with torque after SYNC k-1 -> latched at SYNC k -> the plant integrates it over
  // [t_k, t_k+1], seen as tau_target after SYNC k+1's advance.
  for (const auto& d : cfg.drives) send(fw::encode_rpdo1(d.node_id, {0x0F, 200}));
  cycle(0x0F, 200, false);  // SYNC k: latch
  EXPECT_EQ(plant->output().tau_target.norm(), 0.0);
  cycle(0x0F, 200);  // SYNC k+1: [t_k, t_k+1] integrated with 10 N m
  for (int i = 0; i < 4; ++i) EXPECT_DOUBLE_EQ(plant->output().tau_target[i], 10.0);
}

TEST_F(EmulatorTest, TpdoPositionIsPlantCountsPlusZeroOffset) {
  DriveEmulatorConfig c = default_config();
  c.drives[1].zero_offset = 123456;
  build(c);
  to_operation_enabled();
  for (int k = 0; k < 200; ++k) {
    cycle(0x0F, static_cast<std::int16_t>(k % 2 ? 40 : -40));
    for (const fw::CanFrame& f : drain()) {
      const fw::Result<fw::DriveFeedback> fb = fw::decode_tpdo1(f);
      if (!fb) continue;
      const int i = static_cast<int>(f.id - 0x181);
      EXPECT_EQ(fb->position,
                static_cast<std::int32_t>(plant->output().counts[static_cast<std::size_t>(i)] +
                                          (i == 1 ? 123456 : 0)));
    }
  }
  EXPECT_GT(plant->output().time, 0.19);
}

// ---- heartbeats ---------------------------------------------------------------------------

TEST_F(EmulatorTest, HeartbeatProducerPeriod) {
  power_on();
  write(1, od::kProducerHeartbeat, 10);  // at t = 0
  std::vector<std::uint64_t> times;
  for (std::uint64_t t = 0; t <= 35 * kMs; t += kMs / 2) {
    at(t);
    for (const fw::CanFrame& f : only(0x701)) {
      EXPECT_EQ(f, frame(0x701, {0x7F}));  // pre-operational
      times.push_back(f.timestamp_ns);
    }
  }
  EXPECT_EQ(times, (std::vector<std::uint64_t>{10 * kMs, 20 * kMs, 30 * kMs}));
}

TEST_F(EmulatorTest, MasterHeartbeatLossReactsAtTNotBefore) {
  DriveEmulatorConfig c = default_config();
  c.free_run_after_ns = 0;  // no SYNCs in this test: keep the RPDO watchdog out of it
  build(c);
  to_operation_enabled();
  const std::uint64_t t0 = hub->now_ns();
  write_all(od::consumer_heartbeat(1), fw::consumer_heartbeat_value(127, 50));
  send(fw::encode_heartbeat(127, fw::NmtState::kOperational));  // arms the consumer
  at(t0);
  drain();
  at(t0 + 50 * kMs - 1);  // T - 1 ns
  EXPECT_EQ(emu->status(0).state, Cia402State::kOperationEnabled);
  EXPECT_TRUE(drain().empty());
  at(t0 + 50 * kMs);  // T: 6007h = 3, quick stop
  EXPECT_EQ(emu->status(0).state, Cia402State::kQuickStopActive);
  EXPECT_TRUE(emu->status(0).heartbeat_lost);
  // EMCY 8130h, error register generic + communication (11h).
  EXPECT_EQ(only(0x081),
            (std::vector<fw::CanFrame>{frame(0x081, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0})}));
  // The heartbeat back: error reset EMCY.
  send(fw::encode_heartbeat(127, fw::NmtState::kOperational));
  at(t0 + 60 * kMs);
  EXPECT_EQ(only(0x081), (std::vector<fw::CanFrame>{frame(0x081, {0, 0, 0, 0, 0, 0, 0, 0})}));
  EXPECT_FALSE(emu->status(0).heartbeat_lost);
}

TEST_F(EmulatorTest, HeartbeatLossWithFaultOption) {
  DriveEmulatorConfig c = default_config();
  c.free_run_after_ns = 0;
  build(c);
  to_operation_enabled();
  write(1, od::kAbortConnectionOption, 1);
  write(1, od::consumer_heartbeat(1), fw::consumer_heartbeat_value(127, 20));
  const std::uint64_t t0 = hub->now_ns();
  send(fw::encode_heartbeat(127, fw::NmtState::kOperational));
  at(t0);
  at(t0 + 19 * kMs);
  EXPECT_EQ(emu->status(0).state, Cia402State::kOperationEnabled);
  at(t0 + 20 * kMs);
  EXPECT_EQ(emu->status(0).state, Cia402State::kFault);
  EXPECT_EQ(emu->status(0).error_code, fw::emcy::kHeartbeatError);
}

// ---- watchdogs -----------------------------------------------------------------------------

TEST_F(EmulatorTest, RpdoWatchdogRemovesTorqueAtKMissedCycles) {
  ASSERT_EQ(cfg.rpdo_watchdog_cycles, 3u);
  to_operation_enabled();
  cycle(0x0F, 100);
  EXPECT_DOUBLE_EQ(emu->status(0).torque_nm, 5.0);
  drain();
  cycle(0x0F, 0, false);  // miss 1
  cycle(0x0F, 0, false);  // miss 2 = k - 1: the last torque is still held
  EXPECT_DOUBLE_EQ(emu->status(0).torque_nm, 5.0);
  EXPECT_EQ(emu->status(0).state, Cia402State::kOperationEnabled);
  EXPECT_EQ(emu->status(0).watchdog_missed, 2u);
  EXPECT_TRUE(only(0x081).empty());
  cycle(0x0F, 0, false);  // miss 3 = k: torque off from this SYNC, Fault, EMCY 8250h
  EXPECT_EQ(emu->status(0).torque_nm, 0.0);
  EXPECT_EQ(plant->output().tau_command.norm(), 0.0);
  EXPECT_EQ(emu->status(0).state, Cia402State::kFault);
  EXPECT_EQ(emu->status(0).counters.watchdog_trips, 1u);
  EXPECT_EQ(only(0x081),
            (std::vector<fw::CanFrame>{frame(0x081, {0x50, 0x82, 0x11, 0, 0, 0, 0, 0})}));
}

TEST_F(EmulatorTest, RpdoDeadlineFromEventTimer) {
  DriveEmulatorConfig c = default_config();
  c.rpdo_watchdog_cycles = 0;  // only the 1400h sub5 deadline
  build(c);
  power_on();
  write(1, od::pdo_event_timer(od::PdoDirection::kRpdo, 1), 10);
  write_all(od::kModesOfOperation, 10);
  send(fw::encode_nmt(fw::NmtCommand::kStart, 0));
  now();
  cycle(0x06, 0);
  cycle(0x07, 0);
  cycle(0x0F, 0);
  const std::uint64_t last_rx = hub->now_ns() - cfg.sync_period_ns;
  drain();
  at(last_rx + 10 * kMs - 1);
  EXPECT_EQ(emu->status(0).state, Cia402State::kOperationEnabled);
  at(last_rx + 10 * kMs);  // 6007h = 3: quick stop, EMCY 8250h
  EXPECT_EQ(emu->status(0).state, Cia402State::kQuickStopActive);
  EXPECT_EQ(emu->status(0).counters.deadline_trips, 1u);
  EXPECT_EQ(only(0x081).size(), 1u);
  EXPECT_EQ(emu->status(1).state, Cia402State::kOperationEnabled);  // no deadline there
}

TEST_F(EmulatorTest, DeadMasterPlantFreeRunsAndWatchdogTrips) {
  to_operation_enabled();
  cycle(0x0F, 100);
  const double t_plant = plant->output().time;
  const std::uint64_t last = hub->now_ns() - cfg.sync_period_ns;
  at(last + cfg.free_run_after_ns - 1);
  EXPECT_EQ(emu->virtual_syncs(), 0u);
  at(last + cfg.free_run_after_ns);
  EXPECT_EQ(emu->virtual_syncs(), cfg.free_run_after_ns / cfg.sync_period_ns);
  EXPECT_NEAR(plant->output().time - t_plant, 0.050, 1e-9);
  EXPECT_EQ(emu->status(0).state, Cia402State::kFault);  // watchdog, k = 3 virtual misses
  EXPECT_EQ(emu->status(0).torque_nm, 0.0);
}

// ---- EMCY, e-stop, injection ----------------------------------------------------------------

TEST_F(EmulatorTest, EmcyOnInjectedFaultAndErrorResetAfterFaultReset) {
  power_on();
  emu->inject_fault(0, fw::emcy::kContinuousOverCurrent);
  // 2310h, error register generic + current = 03h (CiA 301 7.2.7.3.1).
  EXPECT_EQ(drain(), (std::vector<fw::CanFrame>{frame(0x081, {0x10, 0x23, 0x03, 0, 0, 0, 0, 0})}));
  EXPECT_EQ(read(1, od::kErrorCode), 0x2310u);
  EXPECT_EQ(read(1, od::kErrorRegister), 0x03u);
  write(1, od::kControlword, 0x00);
  write(1, od::kControlword, 0x80);
  EXPECT_EQ(only(0x081), (std::vector<fw::CanFrame>{frame(0x081, {0, 0, 0, 0, 0, 0, 0, 0})}));
  EXPECT_EQ(read(1, od::kErrorCode), 0u);
  const fw::Result<fw::Emcy> e = fw::decode_emcy(frame(0x081, {0, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_TRUE(e->is_reset());
}

TEST_F(EmulatorTest, EstopInputIsStoAndVisibleIn60FDh) {
  to_operation_enabled();
  cycle(0x0F, 100);
  emu->press_estop(true);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(emu->status(i).state, Cia402State::kSwitchOnDisabled);
    EXPECT_EQ(emu->status(i).last_transition, 9);
    EXPECT_EQ(emu->status(i).torque_nm, 0.0);
  }
  EXPECT_EQ(plant->output().tau_command.norm(), 0.0);  // at once, not at the next SYNC
  EXPECT_EQ(read(1, od::kDigitalInputs), od::kDigitalInputEstopMask);
  EXPECT_TRUE(only(0x081).empty());  // not a fault
  // Transition 2 refused while the circuit is open; the statusword shows a warning.
  cycle(0x06, 0);
  EXPECT_EQ(emu->status(0).state, Cia402State::kSwitchOnDisabled);
  EXPECT_NE(emu->status(0).statusword & fw::sw::kWarning, 0);
  emu->press_estop(false);
  cycle(0x0F, 100);  // never back to Operation enabled by itself
  EXPECT_EQ(emu->status(0).state, Cia402State::kSwitchOnDisabled);
  cycle(0x06, 0);
  EXPECT_EQ(emu->status(0).state, Cia402State::kReadyToSwitchOn);
  EXPECT_EQ(read(1, od::kDigitalInputs), 0u);
}

TEST_F(EmulatorTest, RefuseBootSilentAndDroppedTpdos) {
  emu->set_refuse_boot(2, true);
  const std::vector<fw::CanFrame> boot = power_on();
  EXPECT_EQ(boot.size(), 3u);
  EXPECT_EQ(emu->status(2).nmt, EmulatedNmt::kInitialisation);
  send(fw::encode_nmt(fw::NmtCommand::kResetNode, 0));
  now();
  EXPECT_TRUE(only(0x703).empty());
  emu->set_refuse_boot(2, false);
  now();
  EXPECT_EQ(only(0x703).size(), 1u);
  drain();
  // Silent: no answer, no TPDO.
  emu->set_silent(0, true);
  send(fw::sdo_upload_initiate(1, 0x6041, 0));
  now();
  EXPECT_TRUE(drain().empty());
  emu->set_silent(0, false);
  send(fw::encode_nmt(fw::NmtCommand::kStart, 0));
  now();
  emu->drop_tpdos(1, 2);
  for (int k = 0; k < 3; ++k) cycle(0, 0);
  const std::vector<fw::CanFrame> f = drain();
  EXPECT_EQ(std::count_if(f.begin(), f.end(), [](const fw::CanFrame& x) { return x.id == 0x182; }),
            1);
  EXPECT_EQ(std::count_if(f.begin(), f.end(), [](const fw::CanFrame& x) { return x.id == 0x181; }),
            3);
  EXPECT_EQ(emu->status(1).counters.tpdos_dropped, 2u);
}

TEST_F(EmulatorTest, EncoderJumpShowsInTheTpdo) {
  to_operation_enabled();
  cycle(0x0F, 0);
  drain();
  emu->inject_encoder_offset(3, 5000);
  cycle(0x0F, 0);
  const std::vector<fw::CanFrame> t = only(0x184);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(fw::decode_tpdo1(t.front())->position, plant->output().counts[3] + 5000);
}

TEST_F(EmulatorTest, NmtStopInOperationEnabledPerformsTheAbortReaction) {
  to_operation_enabled();
  send(fw::encode_nmt(fw::NmtCommand::kStop, 1));
  now();
  EXPECT_EQ(emu->status(0).state, Cia402State::kQuickStopActive);
  EXPECT_EQ(emu->status(1).state, Cia402State::kOperationEnabled);
}

TEST_F(EmulatorTest, ForeignFramesAreCountedNotFatal) {
  power_on();
  send(frame(0x123, {1, 2, 3}));
  send(frame(0x081, {0x00, 0x10, 0x01, 0, 0, 0, 0, 0}));  // an EMCY of node 1 from elsewhere
  fw::CanFrame ext = frame(0x1234567, {1});
  ext.extended = true;
  send(ext);
  send(frame(0x080, {1, 2}));  // SYNC with DLC 2
  now();
  EXPECT_EQ(emu->unhandled_frames(), 4u);
  EXPECT_EQ(emu->syncs(), 0u);
}

// ---- no allocation in the frame path --------------------------------------------------------

TEST_F(EmulatorTest, FramePathAllocatesNothing) {
  to_operation_enabled();
  write_all(od::consumer_heartbeat(1), fw::consumer_heartbeat_value(127, 100));
  write_all(od::kProducerHeartbeat, 10);
  std::array<fw::CanFrame, 16> rpdo{};
  for (std::size_t i = 0; i < 4; ++i)
    rpdo[i] = *fw::encode_rpdo1(static_cast<std::uint8_t>(i + 1), {0x0F, 20});
  const fw::CanFrame sync = *fw::encode_sync();
  const fw::CanFrame hb = *fw::encode_heartbeat(127, fw::NmtState::kOperational);
  const fw::CanFrame up = *fw::sdo_upload_initiate(2, 0x6064, 0);
  fw::CanFrame rx;
  std::uint64_t t = hub->now_ns();
  long received = 0;
  dualv::test::start_counting();
  for (int k = 0; k < 2000; ++k) {
    for (std::size_t i = 0; i < 4; ++i) master().send(rpdo[i]);
    master().send(sync);
    if (k % 10 == 0) master().send(hb);
    if (k % 100 == 0) master().send(up);
    if (k == 1000) emu->inject_fault(1, fw::emcy::kCurrent);
    hub->set_time_ns(t);
    emu->poll(t);
    t += cfg.sync_period_ns;
    while (master().receive(rx) == drivers::BusStatus::kOk) ++received;
  }
  const long allocations = dualv::test::stop_counting();
  EXPECT_EQ(allocations, 0);
  EXPECT_GT(received, 8000);
  EXPECT_EQ(emu->status(1).state, Cia402State::kFault);
}

}  // namespace
}  // namespace dualv::sim
