// drivers/canopen/eds_check.hpp: the shipped EDS (config/eds/dualv-emulated-drive.eds) has
// everything the shipped `can:` section needs; each defect a vendor's EDS may have (an
// object missing, not mappable, of the wrong type or access) is named, and an optional
// object the drive lacks is reported as skipped with its safety consequence.
#include "drivers/canopen/eds_check.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "drivers/canopen_config.hpp"
#include "firmware_if/eds.hpp"

namespace dualv::drivers::canopen {
namespace {

namespace eds = fw::eds;

eds::Eds shipped() {
  return eds::read_eds_file(std::string(DUALV_SOURCE_DIR) + "/config/eds/dualv-emulated-drive.eds");
}
CanConfig config() {
  return load_can_config_file(std::string(DUALV_SOURCE_DIR) + "/config/dualv.yaml");
}

eds::Eds without(eds::Eds e, std::uint16_t index) {
  e.objects.erase(std::remove_if(e.objects.begin(), e.objects.end(),
                                 [index](const eds::EdsObject& o) { return o.index == index; }),
                  e.objects.end());
  return e;
}
eds::EdsEntry& at(eds::Eds& e, std::uint16_t index, std::uint8_t sub) {
  for (eds::EdsObject& o : e.objects)
    for (eds::EdsEntry& x : o.entries)
      if (x.index == index && x.subindex == sub) return x;
  throw std::logic_error("no such entry in the test EDS");
}

// The shipped EDS as text, without the section [IIIIsubS] of object `index` (and SubNumber one
// less, so the file stays consistent): a vendor's record that lacks that one sub-index.
// `object_line` is set to the line of the object's own section [IIII], counted here.
std::string text_without_sub_index(const std::string& index, int sub, int& object_line) {
  std::ifstream in(std::string(DUALV_SOURCE_DIR) + "/config/eds/dualv-emulated-drive.eds");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t s = text.find("[" + index + "sub" + std::to_string(sub) + "]\n");
  const std::size_t next = text.find("\n[", s);
  if (s == std::string::npos || next == std::string::npos) throw std::logic_error("no section");
  text.erase(s, next + 1 - s);
  const std::size_t o = text.find("[" + index + "]\n");
  const std::size_t n = text.find("SubNumber=", o);
  const std::size_t end = text.find('\n', n);
  const int count = std::stoi(text.substr(n + 10, end - n - 10));
  text.replace(n, end - n, "SubNumber=" + std::to_string(count - 1));
  object_line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + o, '\n'));
  return text;
}

bool has(const std::vector<std::string>& lines, const std::string& s) {
  return std::any_of(lines.begin(), lines.end(),
                     [&s](const std::string& l) { return l.find(s) != std::string::npos; });
}

TEST(EdsCheck, ShippedEdsBootsWithTheShippedConfiguration) {
  const eds::Eds e = shipped();
  const CanConfig c = config();
  ASSERT_EQ(c.size(), 4);
  for (int i = 0; i < c.size(); ++i) {
    const EdsCheckReport r = check_eds(e, c, i);
    EXPECT_EQ(r.node, c.drives[static_cast<std::size_t>(i)].node_id);
    EXPECT_TRUE(r.can_boot()) << ::testing::PrintToString(r.problems);
    EXPECT_TRUE(r.skipped.empty()) << ::testing::PrintToString(r.skipped);
  }
}

TEST(EdsCheck, OptionalObjectMissingIsSkipped) {
  const EdsCheckReport r = check_eds(without(shipped(), 0x60C2), config(), 1);
  EXPECT_TRUE(r.can_boot()) << ::testing::PrintToString(r.problems);
  ASSERT_EQ(r.skipped.size(), 1u);
  EXPECT_EQ(
      r.skipped[0],
      "node 2: interpolation_period skipped (optional): 60C2h sub1 (interpolation time period "
      "value) is not in the EDS (boot writes it)");
  EXPECT_TRUE(has(r.notes, "node 2: 60C2h absent"));
}

// An object the EDS has, lacking one sub-index boot writes: a problem naming the file, the
// object's line, the object and the sub-index, even though 60C2h is optional (an optional
// object is absent as a whole, never in part), not a skip.
TEST(EdsCheck, ARecordWithoutOneSubIndexIsAProblemEvenWhenOptional) {
  int line = 0;
  const eds::Eds e = eds::parse_eds(text_without_sub_index("60C2", 2, line), "vendor.eds");
  ASSERT_NE(e.object(0x60C2), nullptr);
  ASSERT_EQ(e.entry(0x60C2, 2), nullptr);
  const CanConfig c = config();
  ASSERT_EQ(c.drives[0].objects.interpolation_period, ObjectPolicy::kOptional);
  const EdsCheckReport r = check_eds(e, c, 0);
  EXPECT_FALSE(r.can_boot());
  EXPECT_TRUE(r.skipped.empty()) << ::testing::PrintToString(r.skipped);
  ASSERT_EQ(r.problems.size(), 1u) << ::testing::PrintToString(r.problems);
  EXPECT_TRUE(has(r.problems, "node 1: vendor.eds:" + std::to_string(line) +
                                  ": object 60C2h has no sub-index 2 ("))
      << r.problems[0];
  EXPECT_TRUE(has(r.problems, "can.objects.interpolation_period")) << r.problems[0];
}

// The same for a PDO mapping record: TPDO1's mapping 1A00h without its second entry.
TEST(EdsCheck, AMappingRecordWithoutOneSubIndexIsAProblem) {
  int line = 0;
  const eds::Eds e = eds::parse_eds(text_without_sub_index("1A00", 2, line), "vendor.eds");
  const EdsCheckReport r = check_eds(e, config(), 2);
  EXPECT_FALSE(r.can_boot());
  EXPECT_TRUE(has(r.problems, "node 3: vendor.eds:" + std::to_string(line) +
                                  ": object 1A00h has no sub-index 2 ("))
      << ::testing::PrintToString(r.problems);
}

TEST(EdsCheck, RequiredObjectMissingIsAProblem) {
  CanConfig c = config();
  c.drives[0].objects.interpolation_period = ObjectPolicy::kRequired;
  const EdsCheckReport r = check_eds(without(shipped(), 0x60C2), c, 0);
  EXPECT_FALSE(r.can_boot());
  EXPECT_TRUE(has(r.problems, "node 1: 60C2h sub1 (interpolation time period value)"));
  EXPECT_TRUE(has(r.problems, "can.objects.interpolation_period is required"));
  EXPECT_EQ(r.problems.size(), 1u) << ::testing::PrintToString(r.problems);  // boot stops there
  // Off: never written, neither skipped nor a problem.
  c.drives[0].objects.interpolation_period = ObjectPolicy::kOff;
  const EdsCheckReport off = check_eds(without(shipped(), 0x60C2), c, 0);
  EXPECT_TRUE(off.can_boot());
  EXPECT_TRUE(off.skipped.empty());
}

TEST(EdsCheck, MandatoryObjectMissingIsAProblem) {
  const EdsCheckReport r = check_eds(without(shipped(), 0x6060), config(), 0);
  EXPECT_FALSE(r.can_boot());
  EXPECT_TRUE(has(r.problems, "node 1: 6060h sub0 (modes of operation)"));
  EXPECT_TRUE(has(r.problems, "is not in the EDS"));
}

TEST(EdsCheck, PdoObjectsMustBeMappableWithTheRightAccess) {
  eds::Eds e = shipped();
  at(e, 0x6071, 0).pdo_mappable = false;      // RPDO1
  at(e, 0x6040, 0).access = fw::Access::kRo;  // RPDO1: the master writes it
  at(e, 0x6040, 0).access_text = "ro";
  at(e, 0x6041, 0).access = fw::Access::kWo;  // TPDO1: the drive sends it
  at(e, 0x6041, 0).access_text = "wo";
  const EdsCheckReport r = check_eds(e, config(), 0);
  EXPECT_FALSE(r.can_boot());
  EXPECT_TRUE(has(r.problems, "node 1: 6071h sub0 (target torque) is not PDO-mappable in the EDS"));
  EXPECT_TRUE(has(r.problems, "but an RPDO carries it"));
  EXPECT_TRUE(has(r.problems, "node 1: 6040h sub0 (controlword) is ro in the EDS (line"));
  EXPECT_TRUE(has(r.problems, "): an RPDO needs it writable"));
  EXPECT_TRUE(has(r.problems, "node 1: 6041h sub0 (statusword) is wo in the EDS (line"));
  EXPECT_TRUE(has(r.problems, "): a TPDO needs it readable"));
  EXPECT_EQ(r.problems.size(), 3u) << ::testing::PrintToString(r.problems);
}

TEST(EdsCheck, WrongDataTypeIsAProblem) {
  eds::Eds e = shipped();
  at(e, 0x6064, 0).data_type = 0x0003;  // INTEGER16, mapped as 32 bits
  const EdsCheckReport r = check_eds(e, config(), 0);
  EXPECT_TRUE(has(r.problems, "6064h sub0 (position actual value) is INTEGER16 in the EDS (line"));
  EXPECT_TRUE(has(r.problems, "the stack uses INTEGER32"));
  EXPECT_TRUE(has(r.problems, "is 16 bits in the EDS"));
  EXPECT_TRUE(has(r.problems, "mapped as 32"));
}

TEST(EdsCheck, WrittenObjectMustBeWritable) {
  eds::Eds e = shipped();
  at(e, 0x1017, 0).access = fw::Access::kConst;
  at(e, 0x1017, 0).access_text = "const";
  const EdsCheckReport r = check_eds(e, config(), 0);
  ASSERT_EQ(r.problems.size(), 1u) << ::testing::PrintToString(r.problems);
  EXPECT_NE(r.problems[0].find("1017h sub0 (producer heartbeat time (ms)) is const in the EDS"),
            std::string::npos)
      << r.problems[0];
}

TEST(EdsCheck, ParameterReadsAndProfile) {
  eds::Eds e = shipped();
  at(e, 0x1000, 0).default_value = "0x00020191";  // profile 401, not 402
  at(e, 0x6502, 0).default_value = "0x00000100";  // CSV (bit 8), not CST (bit 9)
  const EdsCheckReport r = check_eds(without(e, 0x6076), config(), 0);
  EXPECT_TRUE(has(r.problems, "1000h DefaultValue 00020191h"));
  EXPECT_TRUE(has(r.problems, "is not a CiA 402 device"));
  EXPECT_TRUE(has(r.problems, "6502h DefaultValue 00000100h"));
  EXPECT_TRUE(
      has(r.problems, "6076h sub0 (motor rated torque (mN m)) is not in the EDS (boot reads it"));
  // Without check_drive_parameters nothing is read.
  CanConfig c = config();
  c.check_drive_parameters = false;
  EXPECT_TRUE(check_eds(without(e, 0x6076), c, 0).can_boot());
}

TEST(EdsCheck, SafetyConsequences) {
  // 6007h required (shipped): a drive without it cannot boot.
  const EdsCheckReport required = check_eds(without(shipped(), 0x6007), config(), 0);
  EXPECT_TRUE(has(required.problems, "can.objects.abort_connection is required"));
  // Optional: skipped, the heartbeat consumer 1016h is what stops the drive.
  CanConfig c = config();
  c.drives[0].objects.abort_connection = ObjectPolicy::kOptional;
  const EdsCheckReport optional = check_eds(without(shipped(), 0x6007), c, 0);
  EXPECT_TRUE(optional.can_boot()) << ::testing::PrintToString(optional.problems);
  EXPECT_TRUE(has(optional.skipped, "node 1: abort_connection skipped (optional)"));
  EXPECT_TRUE(has(optional.notes, "1016h (required) is what stops it"));
  // Neither 6007h nor 1016h: nothing stops the drive when the host is gone.
  c.drives[0].objects.consumer_heartbeat = ObjectPolicy::kOptional;
  const EdsCheckReport neither = check_eds(without(without(shipped(), 0x6007), 0x1016), c, 0);
  EXPECT_TRUE(has(neither.problems, "neither 6007h nor 1016h sub1"));
  // The e-stop input: required by default.
  const EdsCheckReport din = check_eds(without(shipped(), 0x60FD), config(), 0);
  EXPECT_TRUE(has(din.problems,
                  "60FDh sub0 (digital inputs) (mapped into a TPDO at 1A01h) is not in the EDS"));
  EXPECT_TRUE(has(din.problems, "can.objects.digital_inputs is required"));
}

}  // namespace
}  // namespace dualv::drivers::canopen
