// sim/canopen/eds_dictionary.hpp and the shipped EDS of the emulated drive
// (config/eds/dualv-emulated-drive.eds): the emulator's dictionary and the EDS agree entry by
// entry both ways (type, access, PDO mapping, power-on value), a disagreement is found, and
// an EDS decides the emulated drive's objects (`dualv sim --eds`): without 60C2h the drive
// answers 06020000h for it, and the real master boots it over the in-process bus, skipping
// the optional 60C2h.
#include "sim/canopen/eds_dictionary.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "drivers/canopen_config.hpp"
#include "drivers/canopen_setup.hpp"
#include "firmware_if/eds.hpp"
#include "sim/drive_emulator.hpp"
#include "sim/in_process_can_rig.hpp"
#include "tests/sim/emulator_fixture.hpp"
#include "tests/sim/sim_fixture.hpp"
#include "tests/support/can_rig_time.hpp"

namespace dualv::sim {
namespace {

namespace eds = fw::eds;

std::string shipped_eds() {
  return std::string(DUALV_SOURCE_DIR) + "/config/eds/dualv-emulated-drive.eds";
}

// `e` without object `index` (as if its sections were not in the file).
eds::Eds without(eds::Eds e, std::uint16_t index) {
  e.objects.erase(std::remove_if(e.objects.begin(), e.objects.end(),
                                 [index](const eds::EdsObject& o) { return o.index == index; }),
                  e.objects.end());
  return e;
}

DriveEmulatorConfig shipped_emulator_config() {
  return emulator_config_from(drivers::load_can_config_file(test::config_file()));
}

TEST(EmulatedDriveEds, MatchesTheEmulatorsDictionaryBothWays) {
  const eds::Eds e = eds::read_eds_file(shipped_eds());
  const DriveEmulatorConfig cfg = shipped_emulator_config();
  drivers::InProcessHub hub(2, 64);
  Plant plant(test::dual_v(),
              emulator_plant_config(load_plant_config_file(test::config_file()), cfg));
  DriveEmulator emu(hub.endpoint(0), plant, cfg);
  std::size_t eds_entries = 0;
  for (const eds::EdsObject& o : e.objects) eds_entries += o.entries.size();
  for (int i = 0; i < emu.size(); ++i) {
    const canopen::ObjectDictionary& od = emu.dictionary(i);
    EXPECT_EQ(canopen::differences(e, od), std::vector<std::string>{}) << "drive " << i;
    EXPECT_EQ(od.size(), eds_entries);
    // Every DefaultValue is what the drive powers on with (node ids evaluated per drive).
    const std::uint8_t node = cfg.drives[static_cast<std::size_t>(i)].node_id;
    for (const eds::EdsObject& o : e.objects)
      for (const eds::EdsEntry& x : o.entries) {
        const auto v = eds::default_value(x, node);
        ASSERT_TRUE(v.has_value()) << x.index << " sub " << int(x.subindex);
        EXPECT_EQ(*v, od.u(od.find(x.index, x.subindex)))
            << std::hex << x.index << "h sub" << int(x.subindex) << " (line " << std::dec << x.line
            << ") node " << int(node);
      }
  }
  const canopen::EdsDrive d = canopen::drive_from_eds(e, 1, 2);
  EXPECT_TRUE(d.absent_objects.empty());
  EXPECT_EQ(d.vendor_id, cfg.vendor_id);
  EXPECT_EQ(d.product_code, cfg.product_code);
}

TEST(EmulatedDriveEds, DifferencesAreFound) {
  eds::Eds e = without(eds::read_eds_file(shipped_eds()), 0x60C2);
  for (eds::EdsObject& o : e.objects)
    if (o.index == 0x6071) o.entries[0].access = fw::Access::kRo;
  for (eds::EdsObject& o : e.objects)
    if (o.index == 0x6041) o.entries[0].pdo_mappable = false;
  for (eds::EdsObject& o : e.objects)
    if (o.index == 0x6064) o.entries[0].data_type = 0x0003;
  eds::EdsObject extra;
  extra.index = 0x2000;
  extra.entries.push_back(eds::EdsEntry{});
  extra.entries[0].index = 0x2000;
  extra.entries[0].name = "vendor thing";
  e.objects.push_back(extra);
  const DriveEmulatorConfig cfg = shipped_emulator_config();
  drivers::InProcessHub hub(2, 64);
  Plant plant(test::dual_v(),
              emulator_plant_config(load_plant_config_file(test::config_file()), cfg));
  DriveEmulator emu(hub.endpoint(0), plant, cfg);
  const std::vector<std::string> d = canopen::differences(e, emu.dictionary(0));
  auto has = [&d](const std::string& s) {
    return std::any_of(d.begin(), d.end(),
                       [&s](const std::string& m) { return m.find(s) != std::string::npos; });
  };
  EXPECT_EQ(d.size(), 3u + 3u + 1u) << ::testing::PrintToString(d);  // 60C2h sub0..2, 3, 2000h
  EXPECT_TRUE(has("60C2h sub1 (interpolation time period value): in the emulator, not in"));
  EXPECT_TRUE(has("6071h sub0 (target torque): AccessType ro in the EDS, rw in the emulator"));
  EXPECT_TRUE(has("6041h sub0 (statusword): PDOMapping=0 in the EDS, 1 in the emulator"));
  EXPECT_TRUE(has("6064h sub0 (position actual value): DataType INTEGER16 in the EDS, INTEGER32"));
  EXPECT_TRUE(
      has("2000h sub0 (vendor thing): in the EDS, not in the emulator (an object it does "
          "not implement)"));
}

class EdsEmulator : public test::EmulatorTest {};

TEST_F(EdsEmulator, AnEdsWithout60C2GivesADriveWithout60C2) {
  const eds::Eds e = without(eds::read_eds_file(shipped_eds()), 0x60C2);
  DriveEmulatorConfig c = default_config();
  const canopen::EdsDrive d = canopen::drive_from_eds(e, c.vendor_id, c.product_code);
  EXPECT_EQ(d.absent_objects, std::vector<std::uint16_t>{0x60C2});
  c.absent_objects = d.absent_objects;
  build(c);
  EXPECT_EQ(canopen::differences(e, emu->dictionary(0)), std::vector<std::string>{});
  power_on();
  const std::uint8_t node = c.drives[0].node_id;
  EXPECT_EQ(abort_code(sdo(node, fw::sdo_upload_initiate(node, 0x60C2, 1))), 0x06020000u);
  EXPECT_EQ(abort_code(sdo(node, fw::sdo_upload_initiate(node, 0x60C2, 0))), 0x06020000u);
  EXPECT_EQ(read(node, fw::od::kDeviceType), 0x00020192u);
}

// An EDS whose 60C2h record lacks sub-index 2 (SubNumber consistent): the drive has 60C2h, so
// the emulator would have to make up the missing entry; `dualv sim --eds` refuses it instead,
// naming the file, the object's line (counted here), the object and the sub-index.
TEST(EmulatedDriveEds, ARecordWithoutOneSubIndexIsRefusedNotEmulated) {
  std::ifstream in(shipped_eds());
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t s = text.find("[60C2sub2]\n");
  ASSERT_NE(s, std::string::npos);
  text.erase(s, text.find("\n[", s) + 1 - s);
  const std::size_t o = text.find("[60C2]\n");
  const std::size_t n = text.find("SubNumber=3", o);
  ASSERT_NE(n, std::string::npos);
  text.replace(n, 11, "SubNumber=2");
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + o, '\n'));
  const eds::Eds e = eds::parse_eds(text, "vendor.eds");

  const DriveEmulatorConfig cfg = shipped_emulator_config();
  EXPECT_TRUE(canopen::drive_from_eds(e, 0, 0).absent_objects.empty());  // 60C2h is there
  drivers::InProcessHub hub(2, 64);
  Plant plant(test::dual_v(),
              emulator_plant_config(load_plant_config_file(test::config_file()), cfg));
  DriveEmulator emu(hub.endpoint(0), plant, cfg);
  const std::vector<std::string> d = canopen::differences(e, emu.dictionary(0));
  ASSERT_EQ(d.size(), 1u) << ::testing::PrintToString(d);
  EXPECT_EQ(
      d[0].rfind("vendor.eds:" + std::to_string(line) + ": object 60C2h has no sub-index 2 (", 0),
      0u)
      << d[0];
}

TEST(EmulatedDriveEds, AnEdsWithoutPositionActualIsRefused) {
  const eds::Eds e = without(eds::read_eds_file(shipped_eds()), 0x6064);
  DriveEmulatorConfig cfg = shipped_emulator_config();
  cfg.absent_objects = canopen::drive_from_eds(e, 0, 0).absent_objects;
  drivers::InProcessHub hub(2, 64);
  Plant plant(test::dual_v(),
              emulator_plant_config(load_plant_config_file(test::config_file()), cfg));
  try {
    DriveEmulator emu(hub.endpoint(0), plant, cfg);
    ADD_FAILURE() << "an emulator without 6064h was built";
  } catch (const std::invalid_argument& x) {
    EXPECT_NE(std::string(x.what()).find("6064h cannot be left out"), std::string::npos)
        << x.what();
  }
}

TEST(EmulatedDriveEds, TheMasterBootsTheDriveOfAnEdsWithout60C2) {
  const drivers::CanConfig can = drivers::load_can_config_file(test::config_file());
  const eds::Eds e = without(eds::read_eds_file(shipped_eds()), 0x60C2);
  DriveEmulatorConfig cfg = emulator_config_from(can);
  cfg.absent_objects = canopen::drive_from_eds(e, 0, 0).absent_objects;
  InProcessCanRig rig(test::dual_v(), load_plant_config_file(test::config_file()), cfg);
  dualv::test::RigClock clock(rig);
  dualv::test::RigWaiter waiter(rig);
  std::vector<std::string> log;
  auto set = drivers::boot_actuator_set(rig.master_bus(), clock, waiter, can,
                                        [&](const std::string& l) { log.push_back(l); });
  ASSERT_NE(set, nullptr);
  int skipped = 0;
  for (const std::string& l : log)
    skipped += l.find("interpolation_period skipped (optional): 60C2h sub1") != std::string::npos;
  EXPECT_EQ(skipped, 4) << ::testing::PrintToString(log);
}

}  // namespace
}  // namespace dualv::sim
