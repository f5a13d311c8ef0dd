// Boot sequence against scripted fake slaves: golden frames (order and content), a node
// that never boots, SDO abort text, read-back verification, parameter checks, the master's
// heartbeat during boot, nothing half-applied.
#include "drivers/canopen/boot.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "common/config_error.hpp"
#include "drivers/canopen_setup.hpp"
#include "fake_slave.hpp"

namespace dualv::drivers::canopen {
namespace {

using test::FakeSlave;
using test::StepWaiter;

constexpr std::uint64_t kMs = 1'000'000;

CanConfig config_for(int drives) {
  CanConfig c = default_can_config();
  c.drives.resize(static_cast<std::size_t>(drives));
  return c;
}

// A bus with the master (endpoint 0), n fake slaves and a sniffer (last endpoint).
struct Bench {
  explicit Bench(int n) : hub(static_cast<std::size_t>(n) + 2, 4096) {
    for (int i = 0; i < n; ++i)
      slaves.push_back(std::make_unique<FakeSlave>(hub.endpoint(static_cast<std::size_t>(i) + 1),
                                                   static_cast<std::uint8_t>(i + 1)));
    std::vector<FakeSlave*> raw;
    for (auto& s : slaves) raw.push_back(s.get());
    waiter = std::make_unique<StepWaiter>(clock, hub, raw);
  }
  InProcessBus& master_bus() { return hub.endpoint(0); }
  InProcessBus& sniffer() { return hub.endpoint(hub.size() - 1); }
  FakeSlave& slave(int i) { return *slaves[static_cast<std::size_t>(i)]; }
  // Frames the master sent, in order, without its heartbeats.
  std::vector<std::string> master_frames(bool with_heartbeat = false) {
    std::vector<std::string> out;
    for (const fw::CanFrame& f : test::drain(sniffer())) {
      const bool from_slave = (f.id >= 0x181 && f.id <= 0x1FF) ||
                              (f.id >= 0x581 && f.id <= 0x5FF) ||
                              (f.id >= 0x701 && f.id <= 0x77E) || (f.id >= 0x081 && f.id <= 0x0FF);
      if (from_slave) continue;
      if (f.id == 0x77F && !with_heartbeat) continue;
      out.push_back(test::to_text(f));
    }
    return out;
  }

  InProcessHub hub;
  ManualClock clock;
  std::vector<std::unique_ptr<FakeSlave>> slaves;
  std::unique_ptr<StepWaiter> waiter;
};

TEST(Boot, GoldenFramesPerDriveLayout) {
  Bench b(1);
  CanConfig c = config_for(1);
  c.check_drive_parameters = false;
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  boot_drives(m, c);
  // Written from CiA 301 7.2.4.3 (SDO), 7.5.2.35/36 (PDO parameters), CiA 402-2 objects.
  // clang-format off
  const std::vector<std::string> expected = {
      "000#8101",                                      // NMT reset node 1
      "601#2B17100032000000", "601#4017100000000000",  // 1017h = 50 ms
      "601#2300140101020080", "601#4000140100000000",  // 1400h.1 = 80000201h (invalid)
      "601#2F00160000000000", "601#4000160000000000",  // 1600h.0 = 0
      "601#2300160110004060", "601#4000160100000000",  // 1600h.1 = 6040h.0, 16 bit
      "601#2300160210007160", "601#4000160200000000",  // 1600h.2 = 6071h.0, 16 bit
      "601#2F00160002000000", "601#4000160000000000",  // 1600h.0 = 2
      "601#2F00140201000000", "601#4000140200000000",  // 1400h.2 = 1 (synchronous)
      "601#2B0014050A000000", "601#4000140500000000",  // 1400h.5 = 10 ms deadline
      "601#2300140101020000", "601#4000140100000000",  // 1400h.1 = 201h (valid)
      "601#23001801810100C0", "601#4000180100000000",  // 1800h.1 = C0000181h (invalid, no RTR)
      "601#2F001A0000000000", "601#40001A0000000000",  // 1A00h.0 = 0
      "601#23001A0110004160", "601#40001A0100000000",  // 1A00h.1 = 6041h.0, 16 bit
      "601#23001A0220006460", "601#40001A0200000000",  // 1A00h.2 = 6064h.0, 32 bit
      "601#2F001A0002000000", "601#40001A0000000000",  // 1A00h.0 = 2
      "601#2F00180201000000", "601#4000180200000000",  // 1800h.2 = 1 (every SYNC)
      "601#2300180181010040", "601#4000180100000000",  // 1800h.1 = 40000181h (valid)
      "601#23011801810200C0", "601#4001180100000000",  // 1801h.1 = C0000281h (TPDO2 invalid)
      "601#2F011A0000000000", "601#40011A0000000000",  // 1A01h.0 = 0
      "601#23011A012000FD60", "601#40011A0100000000",  // 1A01h.1 = 60FDh.0, 32 bit
      "601#2F011A0001000000", "601#40011A0000000000",  // 1A01h.0 = 1
      "601#2F011802FF000000", "601#4001180200000000",  // 1801h.2 = 255 (on change)
      "601#2B0118030A000000", "601#4001180300000000",  // 1801h.3 = 1 ms inhibit time
      "601#2B01180564000000", "601#4001180500000000",  // 1801h.5 = 100 ms event timer
      "601#2301180181020040", "601#4001180100000000",  // 1801h.1 = 40000281h (valid)
      "601#2F6060000A000000", "601#4060600000000000",  // 6060h = 10 (CST)
      "601#2B726000B0040000", "601#4072600000000000",  // 6072h = 1200 per mille (60 / 50 N m)
      "601#2B5A600002000000", "601#405A600000000000",  // 605Ah = 2
      "601#2B5E600002000000", "601#405E600000000000",  // 605Eh = 2
      "601#2B07600003000000", "601#4007600000000000",  // 6007h = 3 (quick stop)
      "601#23061000E8030000", "601#4006100000000000",  // 1006h = 1000 us
      "601#2FC2600101000000", "601#40C2600100000000",  // 60C2h.1 = 1
      "601#2FC26002FD000000", "601#40C2600200000000",  // 60C2h.2 = -3 (1 x 10^-3 s)
      "601#2316100196007F00", "601#4016100100000000",  // 1016h.1 = node 127, 150 ms
      "000#0101",                                      // NMT start node 1
  };
  // clang-format on
  const std::vector<std::string> got = b.master_frames();
  for (std::size_t i = 0; i < std::min(got.size(), expected.size()); ++i)
    EXPECT_EQ(got[i], expected[i]) << "frame " << i;
  EXPECT_EQ(got.size(), expected.size());
  EXPECT_EQ(b.slave(0).nmt.state(), sim::canopen::NmtSlaveState::kOperational);
  EXPECT_EQ(b.slave(0).get(fw::od::consumer_heartbeat(1)), 0x007F0096u);
}

TEST(Boot, ParameterChecksReadIdentityFirst) {
  Bench b(1);
  CanConfig c = config_for(1);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  boot_drives(m, c);
  const auto frames = b.master_frames();
  ASSERT_GE(frames.size(), 7u);
  EXPECT_EQ(frames[1], "601#4000100000000000");  // 1000h device type
  EXPECT_EQ(frames[2], "601#4002650000000000");  // 6502h supported modes
  EXPECT_EQ(frames[3], "601#4076600000000000");  // 6076h rated torque
  EXPECT_EQ(frames[4], "601#408F600100000000");  // 608Fh.1
  EXPECT_EQ(frames[5], "601#408F600200000000");  // 608Fh.2
}

TEST(Boot, MasterHeartbeatRunsDuringBoot) {
  Bench b(1);
  CanConfig c = config_for(1);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  boot_drives(m, c);
  const auto frames = b.master_frames(true);
  int heartbeats = 0;
  for (const auto& f : frames) heartbeats += f == "77F#05";
  EXPECT_GE(heartbeats, 1);
  EXPECT_EQ(frames.front(), "77F#05");  // before the first NMT command
}

TEST(Boot, NodeThatNeverBootsIsNamedAtExactlyTheTimeout) {
  Bench b(3);
  b.slave(1).boots = false;
  CanConfig c = config_for(3);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  try {
    boot_drives(m, c);
    FAIL() << "no error";
  } catch (const BootTimeoutError& e) {
    EXPECT_EQ(e.nodes(), std::vector<std::uint8_t>{2});
    EXPECT_NE(std::string(e.what()).find("node 2 did not boot within 5 s"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(b.clock.now_ns(), 5000 * kMs);  // waited exactly can.timeouts.boot
  // Nothing half-applied: every node back to pre-operational, none configured.
  const auto frames = b.master_frames();
  EXPECT_EQ(frames.back(), "000#8003");
  for (const auto& f : frames) EXPECT_NE(f.substr(0, 4), "601#");
}

TEST(Boot, LostNmtStartIsSentAgain) {
  Bench b(2);
  b.slave(1).ignore_nmt_starts = 1;
  CanConfig c = config_for(2);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  boot_drives(m, c);
  EXPECT_EQ(b.slave(1).nmt.state(), sim::canopen::NmtSlaveState::kOperational);
  int starts_node2 = 0;
  for (const auto& f : b.master_frames()) starts_node2 += f == "000#0102";
  EXPECT_EQ(starts_node2, 2);
}

TEST(Boot, NodeThatNeverStartsNamed) {
  Bench b(1);
  b.slave(0).ignore_nmt_starts = 1000;
  CanConfig c = config_for(1);
  c.boot_timeout_ns = 1000 * kMs;
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  try {
    boot_drives(m, c);
    FAIL();
  } catch (const BootTimeoutError& e) {
    EXPECT_NE(std::string(e.what()).find("node 1 did not report NMT state operational"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("NMT start sent 7 times within can.timeouts.boot = 1 s"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(b.master_frames().back(), "000#8001");  // back to pre-operational
}

// Issue 13 defect 1: a drive whose SDO server answers every expedited upload without size
// indication (42h, CiA 301 7.2.4.3.6) boots; the read-backs take the object's own size.
TEST(Boot, DriveAnsweringUploadsWithoutSizeBoots) {
  Bench b(1);
  b.slave(0).upload_without_size = true;
  CanConfig c = config_for(1);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  boot_drives(m, c);
  EXPECT_EQ(b.slave(0).nmt.state(), sim::canopen::NmtSlaveState::kOperational);
  bool saw_42 = false;
  for (const fw::CanFrame& f : test::drain(b.sniffer()))
    saw_42 = saw_42 || (f.id == 0x581 && f.data[0] == 0x42);
  EXPECT_TRUE(saw_42);
  EXPECT_EQ(m.read(1, fw::od::kProducerHeartbeat), 50u);
}

// Issue 13 defect 4: a drive without 60C2h (06020000h) boots when the object is optional
// (the shipped default); the skip is logged, and the object's other writes are not sent.
TEST(Boot, OptionalObjectTheDriveLacksIsSkippedAndLogged) {
  Bench b(2);
  b.slave(1).abort_on_write[{0x60C2, 1}] =
      static_cast<std::uint32_t>(fw::SdoAbortCode::kObjectDoesNotExist);
  CanConfig c = config_for(2);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  std::vector<std::string> log;
  const std::vector<SkippedObject> skipped =
      boot_drives(m, c, [&](const std::string& line) { log.push_back(line); });
  ASSERT_EQ(skipped.size(), 1u);
  EXPECT_EQ(skipped[0].node, 2);
  EXPECT_EQ(skipped[0].object, "interpolation_period");
  ASSERT_EQ(log.size(), 1u);
  EXPECT_EQ(log[0],
            "node 2: interpolation_period skipped (optional): 60C2h sub1 (interpolation time "
            "period value) aborted 06020000h object does not exist in the object dictionary");
  EXPECT_EQ(b.slave(0).nmt.state(), sim::canopen::NmtSlaveState::kOperational);
  EXPECT_EQ(b.slave(1).nmt.state(), sim::canopen::NmtSlaveState::kOperational);
  const auto frames = b.master_frames();
  EXPECT_EQ(std::count(frames.begin(), frames.end(), "602#2FC26002FD000000"), 0);  // sub2
  EXPECT_EQ(std::count(frames.begin(), frames.end(), "601#2FC26002FD000000"), 1);
  // The writes after the skipped object still happen: 1016h sub1 on node 2.
  EXPECT_EQ(b.slave(1).get(fw::od::consumer_heartbeat(1)), 0x007F0096u);
}

TEST(Boot, RequiredObjectTheDriveLacksFailsNamingThePolicy) {
  Bench b(1);
  b.slave(0).abort_on_write[{0x60C2, 1}] =
      static_cast<std::uint32_t>(fw::SdoAbortCode::kObjectDoesNotExist);
  CanConfig c = config_for(1);
  c.drives[0].objects.interpolation_period = ObjectPolicy::kRequired;
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  try {
    boot_drives(m, c);
    FAIL() << "no error";
  } catch (const SdoError& e) {
    EXPECT_NE(std::string(e.what()).find("(can.objects.interpolation_period is required; make it "
                                         "optional to boot this drive without it)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(b.slave(0).nmt.state(), sim::canopen::NmtSlaveState::kPreOperational);
}

TEST(Boot, OptionalObjectOtherAbortsStillFail) {
  // 06090030h (invalid value) is not "the drive lacks it": never skipped.
  Bench b(1);
  b.slave(0).abort_on_write[{0x60C2, 1}] =
      static_cast<std::uint32_t>(fw::SdoAbortCode::kInvalidValue);
  CanConfig c = config_for(1);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  EXPECT_THROW(boot_drives(m, c), SdoError);
}

TEST(Boot, ObjectsOffAreNeverWritten) {
  Bench b(1);
  CanConfig c = config_for(1);
  c.drives[0].objects.interpolation_period = ObjectPolicy::kOff;
  c.drives[0].objects.cycle_period = ObjectPolicy::kOff;
  c.drives[0].objects.digital_inputs = ObjectPolicy::kOff;
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  boot_drives(m, c);
  for (const std::string& f : b.master_frames()) {
    EXPECT_EQ(f.find("601#2FC260"), std::string::npos) << f;
    EXPECT_EQ(f.find("601#23061000"), std::string::npos) << f;
    EXPECT_EQ(f.find("601#23011801"), std::string::npos) << f;  // 1801h TPDO2
  }
}

TEST(Boot, CommunicationCyclePeriodWritten) {
  // Issue 13 defect 5: 1006h = SYNC period in us (2.5 ms -> 2500 = 09C4h).
  Bench b(1);
  CanConfig c = config_for(1);
  c.sync_period_ns = 2'500'000;
  c.transition_timeout_ns = 500'000'000;
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  boot_drives(m, c);
  EXPECT_EQ(b.slave(0).get(fw::od::kCommunicationCyclePeriod), 2500u);
  const auto frames = b.master_frames();
  EXPECT_EQ(std::count(frames.begin(), frames.end(), "601#23061000C4090000"), 1);
}

TEST(Boot, SdoAbortNamesNodeObjectAndText) {
  Bench b(2);
  b.slave(1).abort_on_write[{0x6060, 0}] =
      static_cast<std::uint32_t>(fw::SdoAbortCode::kInvalidValue);
  CanConfig c = config_for(2);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  try {
    boot_drives(m, c);
    FAIL() << "no error";
  } catch (const SdoError& e) {
    EXPECT_EQ(e.node(), 2);
    EXPECT_EQ(e.code(), 0x06090030u);
    EXPECT_EQ(std::string(e.what()),
              "node 2: SDO write 6060h sub0 (modes of operation) = 10 aborted by the drive: "
              "06090030h invalid value for parameter (download only)");
  }
  EXPECT_EQ(b.slave(0).nmt.state(), sim::canopen::NmtSlaveState::kPreOperational);  // never started
  EXPECT_EQ(b.slave(1).nmt.state(), sim::canopen::NmtSlaveState::kPreOperational);
}

TEST(Boot, SilentDriveGivesSdoTimeout) {
  Bench b(1);
  b.slave(0).answers_sdo = false;
  CanConfig c = config_for(1);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  try {
    boot_drives(m, c);
    FAIL();
  } catch (const SdoError& e) {
    EXPECT_EQ(e.status(), SdoStatus::kTimeout);
    EXPECT_NE(std::string(e.what()).find(
                  "node 1: SDO read 1000h sub0 (device type) no answer within 0.1 s"),
              std::string::npos)
        << e.what();
  }
}

TEST(Boot, ReadBackMismatchRefused) {
  Bench b(1);
  b.slave(0).ignores_writes = true;
  b.slave(0).set(fw::od::kProducerHeartbeat, 0);  // the drive keeps its own value
  CanConfig c = config_for(1);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  try {
    boot_drives(m, c);
    FAIL();
  } catch (const CanopenError& e) {
    EXPECT_NE(std::string(e.what()).find("node 1: 1017h sub0 (producer heartbeat time (ms))"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("did not take the value"), std::string::npos) << e.what();
  }
}

TEST(Boot, RatedTorqueMismatchNamesTheKey) {
  Bench b(2);
  b.slave(1).set(fw::od::kRatedTorque, 40000);
  b.slave(1).set(fw::od::kEncoderIncrements, 4096);
  CanConfig c = config_for(2);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  try {
    boot_drives(m, c);
    FAIL();
  } catch (const ConfigError& e) {
    ASSERT_EQ(e.problems().size(), 2u) << e.what();
    EXPECT_EQ(e.problems()[0],
              "can.drives[1].rated_torque: 50 N m but node 2 reports 6076h = 40000 mN m (40 N m)");
    EXPECT_NE(
        e.problems()[1].find(
            "can.drives[1].counts_per_revolution: 1048576 but node 2 reports 608Fh = 4096 / 1"),
        std::string::npos);
  }
}

TEST(Boot, NotACia402DriveRefused) {
  Bench b(1);
  b.slave(0).set(fw::od::kDeviceType, 0x00000191);  // CiA 401 I/O module
  CanConfig c = config_for(1);
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  EXPECT_THROW(boot_drives(m, c), ConfigError);
}

TEST(Boot, BroadcastLayoutWrites) {
  CanConfig c = config_for(4);
  c.bus_layout = fw::BusLayout::kBroadcast;
  const std::vector<ConfigWrite> w = boot_writes(c, 1);
  auto find = [&](const fw::OdEntry& e) -> const ConfigWrite* {
    for (const auto& x : w)
      if (x.entry.index == e.index && x.entry.subindex == e.subindex) return &x;
    return nullptr;
  };
  using fw::od::PdoDirection;
  // RPDO2 = the broadcast frame 200h: slot 1 maps 6071h at bytes 2..3, dummies elsewhere.
  ASSERT_NE(find(fw::od::pdo_mapping_entry(PdoDirection::kRpdo, 2, 1)), nullptr);
  EXPECT_EQ(find(fw::od::pdo_mapping_entry(PdoDirection::kRpdo, 2, 1))->value, 0x00030010u);
  EXPECT_EQ(find(fw::od::pdo_mapping_entry(PdoDirection::kRpdo, 2, 2))->value, 0x60710010u);
  EXPECT_EQ(find(fw::od::pdo_mapping_entry(PdoDirection::kRpdo, 2, 4))->value, 0x00030010u);
  EXPECT_EQ(find(fw::od::pdo_event_timer(PdoDirection::kRpdo, 2))->value, 10u);
  EXPECT_EQ(find(fw::od::pdo_transmission_type(PdoDirection::kRpdo, 1))->value, 0xFFu);
  // The last write of COB-ID 1401h is the valid broadcast id.
  const ConfigWrite* last_cob = nullptr;
  for (const auto& x : w)
    if (x.entry.index == 0x1401 && x.entry.subindex == 1) last_cob = &x;
  ASSERT_NE(last_cob, nullptr);
  EXPECT_EQ(last_cob->value, 0x00000200u);
}

TEST(Boot, BroadcastLayoutFeedbackPdos) {
  CanConfig c = config_for(4);
  c.bus_layout = fw::BusLayout::kBroadcast;
  c.statusword_inhibit_ns = 2'500'000;                   // 25 x 100 us
  c.statusword_refresh_ns = 40'000'000;                  // 40 ms
  const std::vector<ConfigWrite> w = boot_writes(c, 2);  // node 3
  auto last = [&](std::uint16_t index, std::uint8_t sub) -> std::int64_t {
    std::int64_t v = -1;
    for (const auto& x : w)
      if (x.entry.index == index && x.entry.subindex == sub) v = x.value;
    return v;
  };
  // TPDO1 (1800h / 1A00h): 183h, every SYNC, 6064h alone (CiA 301 7.5.2.37 / 38).
  EXPECT_EQ(last(0x1800, 1), 0x40000183);
  EXPECT_EQ(last(0x1800, 2), 1);
  EXPECT_EQ(last(0x1A00, 0), 1);
  EXPECT_EQ(last(0x1A00, 1), 0x60640020);
  EXPECT_EQ(last(0x1A00, 2), -1);
  // TPDO3 (1802h / 1A02h): 383h, on change (255), inhibit 25 x 100 us, event timer 40 ms,
  // 6041h alone.
  EXPECT_EQ(last(0x1802, 1), 0x40000383);
  EXPECT_EQ(last(0x1802, 2), 0xFF);
  EXPECT_EQ(last(0x1802, 3), 25);
  EXPECT_EQ(last(0x1802, 5), 40);
  EXPECT_EQ(last(0x1A02, 0), 1);
  EXPECT_EQ(last(0x1A02, 1), 0x60410010);
  // Per-drive: no TPDO3 is touched, TPDO1 is statusword + position.
  c.bus_layout = fw::BusLayout::kPerDrive;
  const std::vector<ConfigWrite> p = boot_writes(c, 2);
  for (const auto& x : p) EXPECT_NE(x.entry.index, 0x1802);
  for (const auto& x : p)
    if (x.entry.index == 0x1A00 && x.entry.subindex == 0 && x.value != 0) {
      EXPECT_EQ(x.value, 2u);
    }
}

TEST(Boot, DriveRefusingDummyMappingNamedWithTheObject) {
  Bench b(2);
  // Node 2 (slot 1) maps a dummy at 1601h sub1 and its torque at sub2.
  b.slave(1).abort_on_write[{0x1601, 1}] =
      static_cast<std::uint32_t>(fw::SdoAbortCode::kCannotBeMapped);
  CanConfig c = config_for(2);
  c.bus_layout = fw::BusLayout::kBroadcast;
  CanopenMaster m(b.master_bus(), b.clock, *b.waiter, drivers::master_config(c));
  try {
    boot_drives(m, c);
    FAIL() << "no error";
  } catch (const SdoError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.node(), 2);
    EXPECT_EQ(e.code(), 0x06040041u);
    EXPECT_NE(what.find("node 2 (can.drives[1]) refuses the CiA 301 dummy mapping entry 0003h (16 "
                        "bits) in 1601h sub1"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("06040041h"), std::string::npos) << what;
    EXPECT_NE(what.find("use per_drive"), std::string::npos) << what;
  }
  EXPECT_EQ(b.slave(0).nmt.state(),
            sim::canopen::NmtSlaveState::kPreOperational);  // nothing started
  EXPECT_EQ(b.slave(1).nmt.state(), sim::canopen::NmtSlaveState::kPreOperational);
}

TEST(Boot, SyncCounterWritten) {
  CanConfig c = config_for(1);
  c.sync_counter_overflow = 20;
  bool found = false;
  for (const auto& x : boot_writes(c, 0))
    found = found || (x.entry.index == 0x1019 && x.value == 20);
  EXPECT_TRUE(found);
}

TEST(Boot, InterpolationPeriod) {
  std::uint8_t v = 0;
  std::int8_t i = 0;
  ASSERT_TRUE(interpolation_period(1'000'000, v, i));
  EXPECT_EQ(v, 1);
  EXPECT_EQ(i, -3);
  ASSERT_TRUE(interpolation_period(500'000, v, i));
  EXPECT_EQ(v, 5);
  EXPECT_EQ(i, -4);
  ASSERT_TRUE(interpolation_period(2'500'000, v, i));
  EXPECT_EQ(v, 25);
  EXPECT_EQ(i, -4);
}

TEST(Boot, BootActuatorSetPrimesPositions) {
  Bench b(4);
  for (int i = 0; i < 4; ++i) b.slave(i).position = 1000 * (i + 1);
  CanConfig c = config_for(4);
  c.drives[2].zero_offset = 3000;
  std::vector<std::string> log;
  auto set = drivers::boot_actuator_set(b.master_bus(), b.clock, *b.waiter, c,
                                        [&](const std::string& s) { log.push_back(s); });
  ASSERT_FALSE(log.empty());
  EXPECT_NE(log.front().find("895 bits/cycle"), std::string::npos) << log.front();
  ActuatorFeedback fb;
  for (auto& s : b.slaves) s->step();
  (void)set->read(fb);
  EXPECT_EQ(fb.n, 4);
  EXPECT_NEAR(fb.drive[0].position, 1000.0 * fw::kTwoPi / (1 << 20), 1e-12);
  EXPECT_NEAR(fb.drive[2].position, 0.0, 1e-12);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(fb.drive[i].state, DriveState::kDisabled);
}

}  // namespace
}  // namespace dualv::drivers::canopen
