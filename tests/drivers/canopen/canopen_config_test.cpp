// The `can:` section: defaults, the shipped config/dualv.yaml, one test per rule (each
// naming its key), and the bus-load refusal.
#include "drivers/canopen_config.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "common/config_error.hpp"
#include "common/yaml_reader.hpp"

namespace dualv::drivers {
namespace {

CanConfig load(const std::string& yaml) { return load_can_config(YAML::Load(yaml)["can"]); }

// Expects a ConfigError whose message contains `needle`.
void expect_error(const std::string& yaml, const std::string& needle) {
  try {
    (void)load(yaml);
    FAIL() << "no error for:\n" << yaml;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos)
        << "message: " << e.what() << "\nexpected to contain: " << needle;
  }
}

TEST(CanConfig, DefaultsAreTheContract) {
  const CanConfig c = default_can_config();
  ASSERT_EQ(c.size(), 4);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(c.drives[i].node_id, i + 1);
  EXPECT_EQ(c.bitrate, 1'000'000u);
  EXPECT_EQ(c.sync_period_ns, 1'000'000u);
  EXPECT_EQ(c.bus_layout, fw::BusLayout::kPerDrive);
  EXPECT_NO_THROW(validate(c));
}

TEST(CanConfig, AbsentSectionGivesDefaults) {
  const CanConfig c = load_can_config(YAML::Node());
  EXPECT_EQ(c.size(), 4);
}

TEST(CanConfig, ShippedConfigLoadsAndFits) {
  const CanConfig c = load_can_config_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
  EXPECT_EQ(c.size(), 4);
  EXPECT_EQ(c.interface, "vcan0");
  EXPECT_EQ(c.master_node_id, 127);
  EXPECT_EQ(c.drive_heartbeat_period_ns, 50'000'000u);
  EXPECT_EQ(c.rpdo_deadline_ns, 10'000'000u);
  EXPECT_EQ(c.digital_inputs_refresh_ns, 100'000'000u);
  EXPECT_EQ(c.drives[3].counts_per_revolution, 1u << 20);
  EXPECT_DOUBLE_EQ(c.drives[3].rated_torque, 50.0);
  EXPECT_TRUE(bus_load_report(c).fits);
  EXPECT_NO_THROW(check_sync_period(c, 0.001));
}

TEST(CanConfig, ReadsEveryKey) {
  const CanConfig c = load(R"(
can:
  interface: can1
  bitrate: 500000
  max_bus_load: 0.8
  max_cyclic_load: 0.75
  bus_layout: broadcast
  controlword_refresh: 0.2
  controlword_inhibit: 0.02
  statusword_inhibit: 0.0035
  statusword_refresh: 0.05
  sync: {period: 0.002, counter_overflow: 10}
  master: {node_id: 100, heartbeat_period: 0.02}
  heartbeat: {drive_period: 0.03, drive_timeout: 0.1, master_timeout: 0.06}
  rpdo_deadline: 0.005
  timeouts: {sdo: 0.05, boot: 2.0, transition: 0.25, stale_cycles: 5}
  options: {abort_connection: 2, quick_stop: 6, fault_reaction: 1}
  check_drive_parameters: false
  drives:
    - {node_id: 5, counts_per_revolution: 4096, rated_torque: 10.0, max_torque: 12.5, zero_offset: -100}
)");
  EXPECT_EQ(c.interface, "can1");
  EXPECT_EQ(c.bitrate, 500'000u);
  EXPECT_DOUBLE_EQ(c.max_bus_load, 0.8);
  EXPECT_EQ(c.bus_layout, fw::BusLayout::kBroadcast);
  EXPECT_EQ(c.controlword_refresh_ns, 200'000'000u);
  EXPECT_DOUBLE_EQ(c.max_cyclic_load, 0.75);
  EXPECT_EQ(c.controlword_inhibit_ns, 20'000'000u);
  EXPECT_EQ(c.statusword_inhibit_ns, 3'500'000u);
  EXPECT_EQ(c.statusword_refresh_ns, 50'000'000u);
  EXPECT_EQ(c.sync_period_ns, 2'000'000u);
  EXPECT_EQ(c.sync_counter_overflow, 10);
  EXPECT_EQ(c.master_node_id, 100);
  EXPECT_EQ(c.master_heartbeat_period_ns, 20'000'000u);
  EXPECT_EQ(c.drive_heartbeat_period_ns, 30'000'000u);
  EXPECT_EQ(c.drive_heartbeat_timeout_ns, 100'000'000u);
  EXPECT_EQ(c.master_heartbeat_timeout_ns, 60'000'000u);
  EXPECT_EQ(c.rpdo_deadline_ns, 5'000'000u);
  EXPECT_EQ(c.sdo_timeout_ns, 50'000'000u);
  EXPECT_EQ(c.boot_timeout_ns, 2'000'000'000u);
  EXPECT_EQ(c.transition_timeout_ns, 250'000'000u);
  EXPECT_EQ(c.stale_cycles, 5u);
  EXPECT_EQ(c.abort_connection, fw::AbortConnectionOption::kDisableVoltage);
  EXPECT_EQ(c.quick_stop, fw::QuickStopOption::kQuickStopRampStay);
  EXPECT_EQ(c.fault_reaction, fw::FaultReactionOption::kSlowDownRamp);
  EXPECT_FALSE(c.check_drive_parameters);
  ASSERT_EQ(c.size(), 1);
  EXPECT_EQ(c.drives[0].node_id, 5);
  EXPECT_EQ(c.drives[0].counts_per_revolution, 4096u);
  EXPECT_EQ(c.drives[0].zero_offset, -100);
  EXPECT_DOUBLE_EQ(c.drives[0].max_torque, 12.5);
}

// ---- one test per rule ----------------------------------------------------------------
TEST(CanConfigRules, UnknownKey) {
  expect_error("can: {bitrat: 1000000}", "can.bitrat: unknown key");
}
TEST(CanConfigRules, UnknownNestedKey) {
  expect_error("can: {sync: {periode: 0.001}}", "can.sync.periode: unknown key");
}
TEST(CanConfigRules, WrongType) {
  expect_error("can: {bitrate: fast}", "can.bitrate: must be a number");
}
TEST(CanConfigRules, EmptyInterface) { expect_error("can: {interface: ''}", "can.interface"); }
TEST(CanConfigRules, Bitrate) {
  expect_error("can: {bitrate: 2000000}", "can.bitrate: must be in");
}
TEST(CanConfigRules, MaxBusLoad) { expect_error("can: {max_bus_load: 1.5}", "can.max_bus_load"); }
TEST(CanConfigRules, Layout) {
  expect_error("can: {bus_layout: multicast}",
               "can.bus_layout: must be per_drive, broadcast or fd (got 'multicast')");
  expect_error("can: {max_cyclic_load: 0.97}",
               "can.max_cyclic_load: must be in (0, can.max_bus_load");
  expect_error("can: {controlword_inhibit: 0.2}",
               "can.controlword_inhibit: must be in (0, can.controlword_refresh = 0.1 s]");
  expect_error("can: {statusword_inhibit: 0.00015}",
               "can.statusword_inhibit: must be a multiple of 0.0001 s");
  expect_error("can: {statusword_inhibit: 0}", "can.statusword_inhibit: must be a multiple");
  expect_error("can: {statusword_refresh: 0.0105}",
               "can.statusword_refresh: must be whole milliseconds");
  expect_error("can: {statusword_refresh: 0.005}",
               "can.statusword_refresh: must be whole milliseconds in [can.statusword_inhibit = "
               "0.01 s");
  expect_error("can: {bus_layout: broadcast, timeouts: {transition: 0.02}}",
               "can.timeouts.transition: 0.02 s is too short for the broadcast layout");
}
TEST(CanConfigRules, BroadcastAtMostFourDrives) {
  expect_error(R"(can:
  bus_layout: broadcast
  sync: {period: 0.002}
  drives: [{node_id: 1}, {node_id: 2}, {node_id: 3}, {node_id: 4}, {node_id: 5}])",
               "can.bus_layout: broadcast carries at most 4");
}
TEST(CanConfigRules, SyncPeriod) {
  expect_error("can: {sync: {period: 0.00001}}", "can.sync.period");
}
TEST(CanConfigRules, SyncCounter) {
  expect_error("can: {sync: {counter_overflow: 1}}", "can.sync.counter_overflow");
  expect_error("can: {sync: {counter_overflow: 241}}", "can.sync.counter_overflow");
}
TEST(CanConfigRules, MasterNodeId) {
  expect_error("can: {master: {node_id: 128}}", "can.master.node_id");
}
TEST(CanConfigRules, MasterNodeIdClashesWithDrive) {
  expect_error("can: {master: {node_id: 2}}", "can.drives[1].node_id: 2 is the master's");
}
TEST(CanConfigRules, WholeMilliseconds) {
  expect_error("can: {heartbeat: {drive_period: 0.0505}}",
               "can.heartbeat.drive_period: must be whole milliseconds");
}
TEST(CanConfigRules, DriveTimeoutLongerThanPeriod) {
  expect_error("can: {heartbeat: {drive_period: 0.1, drive_timeout: 0.1}}",
               "can.heartbeat.drive_timeout");
}
TEST(CanConfigRules, MasterTimeoutLongerThanMasterPeriod) {
  expect_error("can: {master: {heartbeat_period: 0.2}}",
               "can.heartbeat.master_timeout: must be longer");
}
TEST(CanConfigRules, RpdoDeadline) {
  expect_error("can: {rpdo_deadline: 0.001}",
               "can.rpdo_deadline: must be longer than can.sync.period");
  expect_error("can: {rpdo_deadline: -1}", "can.rpdo_deadline: must be >= 0");
}
TEST(CanConfigRules, DigitalInputsRefresh) {
  expect_error("can: {digital_inputs_refresh: 0.0001}",
               "can.digital_inputs_refresh: must be whole milliseconds");
  EXPECT_EQ(load("can: {digital_inputs_refresh: 0}").digital_inputs_refresh_ns, 0u);
}
TEST(CanConfigRules, Timeouts) {
  expect_error("can: {timeouts: {sdo: 0}}", "can.timeouts.sdo");
  expect_error("can: {timeouts: {boot: 0}}", "can.timeouts.boot");
  expect_error("can: {timeouts: {transition: 0.001}}", "can.timeouts.transition");
  expect_error("can: {timeouts: {stale_cycles: 0}}", "can.timeouts.stale_cycles");
}
TEST(CanConfigRules, Options) {
  expect_error("can: {options: {abort_connection: 4}}", "can.options.abort_connection");
  expect_error("can: {options: {quick_stop: 9}}", "can.options.quick_stop");
  expect_error("can: {options: {fault_reaction: -1}}", "can.options.fault_reaction");
}
TEST(CanConfigRules, DrivesCount) {
  expect_error("can: {drives: []}", "can.drives: must list 1..8 drives");
}
TEST(CanConfigRules, DriveNodeIdRequired) {
  expect_error("can: {drives: [{rated_torque: 5}]}", "can.drives[0].node_id: missing");
}
TEST(CanConfigRules, DriveNodeIdRange) {
  expect_error("can: {drives: [{node_id: 0}]}", "can.drives[0].node_id: must be in 1..127");
}
TEST(CanConfigRules, DuplicateNodeId) {
  expect_error("can: {drives: [{node_id: 3}, {node_id: 3}]}",
               "can.drives[1].node_id: 3 is also can.drives[0].node_id");
}
TEST(CanConfigRules, CountsPerRevolution) {
  expect_error("can: {drives: [{node_id: 1, counts_per_revolution: 0}]}",
               "can.drives[0].counts_per_revolution");
}
TEST(CanConfigRules, RatedTorque) {
  expect_error("can: {drives: [{node_id: 1, rated_torque: 0}]}", "can.drives[0].rated_torque");
}
TEST(CanConfigRules, MaxTorque) {
  expect_error("can: {drives: [{node_id: 1, max_torque: -1}]}", "can.drives[0].max_torque");
  expect_error("can: {drives: [{node_id: 1, rated_torque: 0.001, max_torque: 100}]}",
               "more than 65535 per mille");
}
// Issue 13 defect 7: 1000 N m was accepted and 6072h = 20000 per mille written.
TEST(CanConfigRules, MaxTorqueAboveThePeakRefused) {
  // 1000 N m / 50 N m rated = 20000 per mille; the peak 127 N m = 2540 per mille.
  expect_error("can: {drives: [{node_id: 1, max_torque: 1000}]}",
               "can.drives[0].max_torque: 1000 N m (6072h = 20000 per mille of 6076h = 50 N m) is "
               "above the drive's peak can.drives[0].peak_torque = 127 N m (2540 per mille)");
  expect_error("can: {drives: [{node_id: 1, max_torque: 60, peak_torque: 55}]}",
               "can.drives[0].max_torque: 60 N m");
  EXPECT_NO_THROW(load("can: {drives: [{node_id: 1, max_torque: 127, peak_torque: 127}]}"));
}
TEST(CanConfigRules, MaxTorqueAboveTheSafetyLimitRefused) {
  const YAML::Node n = YAML::Load("can: {drives: [{node_id: 1, max_torque: 80}]}")["can"];
  EXPECT_NO_THROW(load_can_config(n));  // no safety limit given: only the peak counts
  try {
    (void)load_can_config(n, 60.0);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("can.drives[0].max_torque: 80 N m is above the safety "
                                         "limit safety.torque.max = 60 N m"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(load_can_config(n, 80.0));
  EXPECT_THROW(check_torque_limits(load_can_config(n), 79.9), ConfigError);
}
TEST(CanConfigRules, SafetyLimitReadFromTheSameFile) {
  const YAML::Node root =
      YAML::Load("safety: {torque: {max: 40.0}}\ncan: {drives: [{node_id: 1, max_torque: 45}]}");
  EXPECT_DOUBLE_EQ(safety_torque_max_of(root), 40.0);
  EXPECT_DOUBLE_EQ(safety_torque_max_of(YAML::Load("can: {}")), 60.0);  // safety's default
  const std::string path = ::testing::TempDir() + "/can_safety_limit.yaml";
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs(
        "safety:\n  torque:\n    max: 40.0\ncan:\n  drives:\n    - {node_id: 1, "
        "max_torque: 45}\n",
        f);
    std::fclose(f);
  }
  try {
    (void)load_can_config_file(path);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("safety.torque.max = 40 N m"), std::string::npos)
        << e.what();
  }
}
TEST(CanConfigRules, ShippedTorquesWithinPeakAndSafety) {
  const std::string path = std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml";
  const CanConfig c = load_can_config_file(path);
  EXPECT_NO_THROW(check_torque_limits(c, safety_torque_max_of(YamlReader::load_file(path))));
}

// ---- boot object policies (issue 13 defect 4) -----------------------------------------
TEST(CanConfig, ObjectPoliciesDefaultsAndOverrides) {
  const CanConfig d = default_can_config();
  EXPECT_EQ(d.drives[0].objects.interpolation_period, ObjectPolicy::kOptional);
  EXPECT_EQ(d.drives[0].objects.cycle_period, ObjectPolicy::kOptional);
  EXPECT_EQ(d.drives[0].objects.abort_connection, ObjectPolicy::kRequired);
  EXPECT_EQ(d.drives[0].objects.consumer_heartbeat, ObjectPolicy::kRequired);
  const CanConfig c = load(R"(
can:
  objects: {interpolation_period: required, quick_stop: optional}
  drives:
    - {node_id: 1}
    - {node_id: 2, objects: {interpolation_period: off, fault_reaction: off}}
)");
  EXPECT_EQ(c.drives[0].objects.interpolation_period, ObjectPolicy::kRequired);
  EXPECT_EQ(c.drives[0].objects.quick_stop, ObjectPolicy::kOptional);
  EXPECT_EQ(c.drives[0].objects.fault_reaction, ObjectPolicy::kRequired);
  EXPECT_EQ(c.drives[1].objects.interpolation_period, ObjectPolicy::kOff);
  EXPECT_EQ(c.drives[1].objects.quick_stop, ObjectPolicy::kOptional);  // from can.objects
  EXPECT_EQ(c.drives[1].objects.fault_reaction, ObjectPolicy::kOff);
}
TEST(CanConfigRules, ObjectPolicyValuesAndKeys) {
  expect_error("can: {objects: {interpolation_period: maybe}}",
               "can.objects.interpolation_period: must be required, optional or off (got 'maybe')");
  expect_error("can: {drives: [{node_id: 1, objects: {interpolation_period: sometimes}}]}",
               "can.drives[0].objects.interpolation_period: must be required, optional or off");
  expect_error("can: {objects: {no_such_object: off}}", "no_such_object");
}
TEST(CanConfigRules, NoAbortConnectionNeedsTheHeartbeatConsumer) {
  expect_error("can: {objects: {abort_connection: optional, consumer_heartbeat: optional}}",
               "can.drives[0].objects.consumer_heartbeat: must be required when "
               "can.drives[0].objects.abort_connection is optional");
  expect_error(
      "can: {drives: [{node_id: 1, objects: {abort_connection: off, "
      "consumer_heartbeat: off}}]}",
      "can.drives[0].objects.consumer_heartbeat: must be required");
  EXPECT_NO_THROW(load("can: {objects: {abort_connection: off}}"));
}
TEST(CanConfigRules, NoHeartbeatConsumerNeedsTheRpdoDeadline) {
  expect_error("can: {rpdo_deadline: 0, objects: {consumer_heartbeat: off}}",
               "needs can.rpdo_deadline > 0");
  EXPECT_NO_THROW(load("can: {objects: {consumer_heartbeat: off}}"));
}
TEST(CanConfig, OnExit) {
  EXPECT_EQ(default_can_config().on_exit, OnExit::kPreOperational);
  EXPECT_EQ(load("can: {on_exit: stopped}").on_exit, OnExit::kStopped);
  EXPECT_EQ(load("can: {on_exit: operational_disabled}").on_exit, OnExit::kOperationalDisabled);
  expect_error("can: {on_exit: off}", "can.on_exit: must be preoperational, stopped or");
}

TEST(CanConfigRules, EveryProblemListedAtOnce) {
  try {
    (void)load("can: {bitrate: 5, master: {node_id: 0}, drives: [{node_id: 1, max_torque: 0}]}");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.problems().size(), 3u) << e.what();
  }
}
TEST(CanConfigRules, SyncPeriodMustEqualControlPeriod) {
  try {
    check_sync_period(default_can_config(), 0.002);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(
        std::string(e.what()).find("can.sync.period: 0.001 s but the control period is 0.002 s"),
        std::string::npos)
        << e.what();
  }
}

// ---- bus load (the model: firmware_if/bus_layout.hpp) ---------------------------------------
TEST(CanBusLoad, ContractNumbers) {
  CanConfig c = default_can_config();
  fw::LayoutLoad r = bus_load_report(c);
  EXPECT_EQ(r.cyclic_bits.total(), 895u);  // docs/architecture.md: 55 + 4 * 95 + 4 * 115
  EXPECT_NEAR(r.cyclic_load, 0.895, 1e-12);
  EXPECT_NEAR(r.total_load, 0.895, 1e-12);          // no event PDOs
  EXPECT_NEAR(r.max_rate_hz, 0.90 / 895e-6, 1e-6);  // the cyclic limit binds
  EXPECT_TRUE(r.fits);
  c.bus_layout = fw::BusLayout::kBroadcast;
  r = bus_load_report(c);
  // "Beating the naive bus limit": 55 + 135 + 4 x 95; events: 2 x 4 frames of 75 bits at
  // most every 10 ms = 60000 bit/s = 6 % of the bus.
  EXPECT_EQ(r.cyclic_bits.total(), 570u);
  EXPECT_NEAR(r.cyclic_load, 0.570, 1e-12);
  EXPECT_NEAR(r.total_load, 0.630, 1e-12);
  const std::string text = format_bus_load(c, r);
  EXPECT_NE(text.find("570 bits/cycle"), std::string::npos) << text;
  EXPECT_NE(text.find("broadcast"), std::string::npos) << text;
  EXPECT_NE(text.find("57.0 % cyclic"), std::string::npos) << text;
  EXPECT_NE(text.find("63.0 % with event PDOs"), std::string::npos) << text;
}

TEST(CanBusLoad, InhibitTimesCountInTheLoad) {
  CanConfig c = default_can_config();
  c.bus_layout = fw::BusLayout::kBroadcast;
  c.statusword_inhibit_ns = 2'000'000;   // 4 x 75 bits / 2 ms = 15 %
  c.controlword_inhibit_ns = 5'000'000;  // 4 x 75 bits / 5 ms = 6 %
  EXPECT_NEAR(bus_load_report(c).total_load, 0.570 + 0.15 + 0.06, 1e-12);
}

TEST(CanBusLoad, TooFastRateRefusedWithTheNumbers) {
  CanConfig c = default_can_config();
  c.sync_period_ns = 500'000;  // 2 kHz: 1.79 Mbit/s worst case
  c.transition_timeout_ns = 500'000'000;
  try {
    (void)require_bus_load_fits(c);
    FAIL();
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("2000.0 Hz with the per_drive layout needs 1790000 bit/s"), std::string::npos)
        << m;
    EXPECT_NE(m.find("895 bits/cycle"), std::string::npos) << m;
    EXPECT_NE(m.find("179.0 % cyclic (can.max_cyclic_load 90.0 %)"), std::string::npos) << m;
    EXPECT_NE(m.find("at most 1005.6 Hz"), std::string::npos) << m;
    EXPECT_NE(m.find("bus_layout: broadcast"), std::string::npos) << m;
  }
  c.bus_layout = fw::BusLayout::kBroadcast;  // 570 bits x 2 kHz = 1.14 Mbit/s: still no
  EXPECT_THROW((void)require_bus_load_fits(c), ConfigError);
  c.sync_period_ns = 1'000'000;
  EXPECT_NO_THROW((void)require_bus_load_fits(c));
}

TEST(CanConfigRules, OldLayoutKeyNamesTheNewOne) {
  expect_error("can: {rpdo_layout: broadcast}", "can.rpdo_layout: renamed can.bus_layout");
}
TEST(CanConfigRules, FdKeys) {
  expect_error("can: {fd: {nominal_bitrate: 1000000, data_bitrate: 5000000}}",
               "can.fd.nominal_bitrate: the nominal (arbitration-phase) rate is can.bitrate");
  expect_error("can: {fd: {data_bitrate: 500000}}",
               "can.fd.data_bitrate: must be in [can.bitrate = 1000000, 8000000] bit/s (got "
               "500000)");
  expect_error("can: {fd: {data_bitrate: 10000000}}", "can.fd.data_bitrate: must be in");
  expect_error("can: {fd: {databitrate: 5000000}}", "can.fd.databitrate: unknown key");
  expect_error(R"(can:
  bus_layout: fd
  drives: [{node_id: 1}, {node_id: 2}, {node_id: 3}, {node_id: 4}, {node_id: 5}]
)",
               "can.bus_layout: fd carries at most 4 drives in one FD RPDO (got 5)");
  const CanConfig c = load("can: {bus_layout: fd, fd: {data_bitrate: 2000000}}");
  EXPECT_EQ(c.bus_layout, fw::BusLayout::kFd);
  EXPECT_EQ(c.data_bitrate, 2'000'000u);
}

TEST(CanBusLoad, FdCarriesTwoPointFiveKilohertzAtFiveMegabit) {
  // Issue 15's target: >= 2.5 kHz at <= 90 %. firmware_if/bus_layout.hpp's worst case for four
  // drives: 220 bits at 1 Mbit/s + 570 data-phase bits at 5 Mbit/s = 334 us a cycle.
  CanConfig c = default_can_config();
  c.bus_layout = fw::BusLayout::kFd;
  c.sync_period_ns = 400'000;  // 2.5 kHz
  c.transition_timeout_ns = 500'000'000;
  const fw::LayoutLoad r = require_bus_load_fits(c);
  EXPECT_NEAR(r.cyclic_load, 334e-6 * 2500.0, 1e-9);
  // The data phase at 2 Mbit/s: 220 us + 285 us = 505 us, 126 % at 2.5 kHz: refused, with the
  // data rate in the message.
  c.data_bitrate = 2'000'000;
  try {
    (void)require_bus_load_fits(c);
    FAIL();
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("2500.0 Hz with the fd layout"), std::string::npos) << m;
    EXPECT_NE(m.find("needs 505.0 us of bus time a cycle worst case (220 bits at 1000000 bit/s + "
                     "570 data-phase bits at can.fd.data_bitrate 2000000 bit/s)"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find("at most 1782.2 Hz"), std::string::npos) << m;  // 0.9 / 505 us
  }
  EXPECT_NE(format_bus_load(c, bus_load_report(c)).find("1000000 / 2000000 (data phase)"),
            std::string::npos);
}

TEST(CanBusLoad, BroadcastCarriesOnePointFiveKilohertz) {
  // Issue 15's target: 1.5 kHz, <= 90 % cyclic (85.5 %), <= 95 % with events (91.5 %).
  CanConfig c = default_can_config();
  c.sync_period_ns = 666'667;
  c.bus_layout = fw::BusLayout::kBroadcast;
  const fw::LayoutLoad r = require_bus_load_fits(c);
  EXPECT_NEAR(r.cyclic_load, 570e-6 * 1e9 / 666'667, 1e-9);
  EXPECT_NEAR(r.total_load, 570e-6 * 1e9 / 666'667 + 0.06, 1e-9);
  // Events at a 5 ms inhibit: 85.5 + 12 % > 95 %: refused, naming the event bound.
  c.statusword_inhibit_ns = 5'000'000;
  c.controlword_inhibit_ns = 5'000'000;
  try {
    (void)require_bus_load_fits(c);
    FAIL();
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("97.5 % with event PDOs at their inhibit times (can.max_bus_load 95.0 %)"),
              std::string::npos)
        << m;
  }
}

TEST(CanBusLoad, JustAboveTheLimit) {
  CanConfig c = default_can_config();
  c.max_cyclic_load = 0.89;  // 89.5 % needed at 1 kHz
  EXPECT_THROW((void)require_bus_load_fits(c), ConfigError);
  c.max_cyclic_load = 0.895;
  EXPECT_NO_THROW((void)require_bus_load_fits(c));
  c.max_bus_load = 0.89;  // below the cyclic limit: refused by the rules
  EXPECT_THROW(validate(c), ConfigError);
}

}  // namespace
}  // namespace dualv::drivers
