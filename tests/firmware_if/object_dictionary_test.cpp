#include "firmware_if/object_dictionary.hpp"

#include <gtest/gtest.h>

#include <set>
#include <utility>

namespace dualv::fw {
namespace {

// Indices, subindices and types as printed in CiA 301 / CiA 402-2 (written out here, not
// taken from the header).
TEST(ObjectDictionary, CommunicationProfileEntries) {
  EXPECT_EQ(od::kDeviceType.index, 0x1000);
  EXPECT_EQ(od::kDeviceType.type, DataType::kUnsigned32);
  EXPECT_EQ(od::kErrorRegister.index, 0x1001);
  EXPECT_EQ(od::kErrorRegister.type, DataType::kUnsigned8);
  EXPECT_EQ(od::kCobIdSync.index, 0x1005);
  EXPECT_EQ(od::kCommunicationCyclePeriod.index, 0x1006);
  EXPECT_EQ(od::kCobIdEmcy.index, 0x1014);
  EXPECT_EQ(od::consumer_heartbeat(1).index, 0x1016);
  EXPECT_EQ(od::consumer_heartbeat(1).subindex, 1);
  EXPECT_EQ(od::consumer_heartbeat(1).type, DataType::kUnsigned32);
  EXPECT_EQ(od::kProducerHeartbeat.index, 0x1017);
  EXPECT_EQ(od::kProducerHeartbeat.type, DataType::kUnsigned16);
  EXPECT_EQ(od::kSyncCounterOverflow.index, 0x1019);
}

TEST(ObjectDictionary, PdoParameterIndices) {
  using od::PdoDirection;
  EXPECT_EQ(od::pdo_communication_index(PdoDirection::kRpdo, 1), 0x1400);
  EXPECT_EQ(od::pdo_communication_index(PdoDirection::kRpdo, 4), 0x1403);
  EXPECT_EQ(od::pdo_communication_index(PdoDirection::kTpdo, 1), 0x1800);
  EXPECT_EQ(od::pdo_communication_index(PdoDirection::kTpdo, 2), 0x1801);
  EXPECT_EQ(od::pdo_mapping_index(PdoDirection::kRpdo, 1), 0x1600);
  EXPECT_EQ(od::pdo_mapping_index(PdoDirection::kRpdo, 2), 0x1601);
  EXPECT_EQ(od::pdo_mapping_index(PdoDirection::kTpdo, 1), 0x1A00);
  EXPECT_EQ(od::pdo_mapping_index(PdoDirection::kTpdo, 4), 0x1A03);
  const OdEntry cob = od::pdo_cob_id(PdoDirection::kTpdo, 1);
  EXPECT_EQ(cob.index, 0x1800);
  EXPECT_EQ(cob.subindex, 1);
  EXPECT_EQ(cob.type, DataType::kUnsigned32);
  EXPECT_EQ(od::pdo_transmission_type(PdoDirection::kRpdo, 1).subindex, 2);
  EXPECT_EQ(od::pdo_transmission_type(PdoDirection::kRpdo, 1).type, DataType::kUnsigned8);
  EXPECT_EQ(od::pdo_inhibit_time(PdoDirection::kTpdo, 1).subindex, 3);
  EXPECT_EQ(od::pdo_event_timer(PdoDirection::kRpdo, 1).subindex, 5);
  EXPECT_EQ(od::pdo_event_timer(PdoDirection::kRpdo, 1).type, DataType::kUnsigned16);
  EXPECT_EQ(od::pdo_mapping_count(PdoDirection::kRpdo, 1).subindex, 0);
  EXPECT_EQ(od::pdo_mapping_count(PdoDirection::kRpdo, 1).type, DataType::kUnsigned8);
  EXPECT_EQ(od::pdo_mapping_entry(PdoDirection::kTpdo, 1, 2).index, 0x1A00);
  EXPECT_EQ(od::pdo_mapping_entry(PdoDirection::kTpdo, 1, 2).subindex, 2);
}

TEST(ObjectDictionary, DriveProfileEntries) {
  struct Expect {
    OdEntry e;
    std::uint16_t index;
    std::uint8_t sub;
    DataType type;
    std::uint8_t size;
  };
  const Expect expected[] = {
      {od::kAbortConnectionOption, 0x6007, 0, DataType::kInteger16, 2},
      {od::kErrorCode, 0x603F, 0, DataType::kUnsigned16, 2},
      {od::kControlword, 0x6040, 0, DataType::kUnsigned16, 2},
      {od::kStatusword, 0x6041, 0, DataType::kUnsigned16, 2},
      {od::kQuickStopOption, 0x605A, 0, DataType::kInteger16, 2},
      {od::kShutdownOption, 0x605B, 0, DataType::kInteger16, 2},
      {od::kDisableOperationOption, 0x605C, 0, DataType::kInteger16, 2},
      {od::kHaltOption, 0x605D, 0, DataType::kInteger16, 2},
      {od::kFaultReactionOption, 0x605E, 0, DataType::kInteger16, 2},
      {od::kModesOfOperation, 0x6060, 0, DataType::kInteger8, 1},
      {od::kModesOfOperationDisplay, 0x6061, 0, DataType::kInteger8, 1},
      {od::kPositionActual, 0x6064, 0, DataType::kInteger32, 4},
      {od::kVelocityActual, 0x606C, 0, DataType::kInteger32, 4},
      {od::kTargetTorque, 0x6071, 0, DataType::kInteger16, 2},
      {od::kMaxTorque, 0x6072, 0, DataType::kUnsigned16, 2},
      {od::kRatedTorque, 0x6076, 0, DataType::kUnsigned32, 4},
      {od::kTorqueActual, 0x6077, 0, DataType::kInteger16, 2},
      {od::kEncoderIncrements, 0x608F, 1, DataType::kUnsigned32, 4},
      {od::kEncoderMotorRevolutions, 0x608F, 2, DataType::kUnsigned32, 4},
      {od::kDigitalInputs, 0x60FD, 0, DataType::kUnsigned32, 4},
      {od::kSupportedDriveModes, 0x6502, 0, DataType::kUnsigned32, 4},
  };
  for (const Expect& x : expected) {
    SCOPED_TRACE(x.e.name);
    EXPECT_EQ(x.e.index, x.index);
    EXPECT_EQ(x.e.subindex, x.sub);
    EXPECT_EQ(x.e.type, x.type);
    EXPECT_EQ(x.e.size(), x.size);
  }
  // The objects carried in the cyclic PDOs must be mappable.
  EXPECT_TRUE(od::kControlword.pdo_mappable);
  EXPECT_TRUE(od::kStatusword.pdo_mappable);
  EXPECT_TRUE(od::kTargetTorque.pdo_mappable);
  EXPECT_TRUE(od::kPositionActual.pdo_mappable);
  EXPECT_EQ(od::kStatusword.access, Access::kRo);
  EXPECT_EQ(od::kControlword.access, Access::kRw);
}

TEST(ObjectDictionary, DataTypeIndicesAndSizes) {
  // CiA 301 table 44: the static data types' own indices.
  EXPECT_EQ(static_cast<int>(DataType::kInteger8), 0x0002);
  EXPECT_EQ(static_cast<int>(DataType::kInteger16), 0x0003);
  EXPECT_EQ(static_cast<int>(DataType::kInteger32), 0x0004);
  EXPECT_EQ(static_cast<int>(DataType::kUnsigned8), 0x0005);
  EXPECT_EQ(static_cast<int>(DataType::kUnsigned16), 0x0006);
  EXPECT_EQ(static_cast<int>(DataType::kUnsigned32), 0x0007);
  EXPECT_EQ(size_of(DataType::kBoolean), 1);
  EXPECT_EQ(size_of(DataType::kInteger16), 2);
  EXPECT_EQ(size_of(DataType::kUnsigned32), 4);
  EXPECT_TRUE(is_signed(DataType::kInteger8));
  EXPECT_FALSE(is_signed(DataType::kUnsigned16));
}

TEST(ObjectDictionary, NoEntryDefinedTwice) {
  std::set<std::pair<std::uint16_t, std::uint8_t>> seen;
  for (const OdEntry& e : od::kAll) {
    EXPECT_TRUE(seen.insert({e.index, e.subindex}).second)
        << std::hex << e.index << ":" << int(e.subindex) << " twice";
  }
}

TEST(ObjectDictionary, EstopInputBitIsManufacturerSpecific) {
  // 60FDh bits 0..15 are profile-defined (limit switches, home, interlock, reserved);
  // the e-stop feedback must use bits 16..31.
  EXPECT_GE(od::kDigitalInputEstopBit, 16u);
  EXPECT_LE(od::kDigitalInputEstopBit, 31u);
  EXPECT_EQ(od::kDigitalInputEstopMask, 0x00010000u);
}

}  // namespace
}  // namespace dualv::fw
