#include "firmware_if/pdo.hpp"

#include <gtest/gtest.h>

#include <random>

#include "frame_builder.hpp"

namespace dualv::fw {
namespace {

using test::make_frame;

TEST(Pdo, MappingEntryEncoding) {
  // 0xIIIISSLL (CiA 301 7.4.7.1).
  EXPECT_EQ(encode_mapping(map_entry(od::kControlword)), 0x60400010u);
  EXPECT_EQ(encode_mapping(map_entry(od::kTargetTorque)), 0x60710010u);
  EXPECT_EQ(encode_mapping(map_entry(od::kStatusword)), 0x60410010u);
  EXPECT_EQ(encode_mapping(map_entry(od::kPositionActual)), 0x60640020u);
  EXPECT_EQ(encode_mapping(map_entry(od::kEncoderMotorRevolutions)), 0x608F0220u);
  EXPECT_EQ(encode_mapping(dummy_entry(DataType::kInteger16)), 0x00030010u);
  EXPECT_EQ(encode_mapping(dummy_entry(DataType::kUnsigned8)), 0x00050008u);
  EXPECT_EQ(decode_mapping(0x60770010u), (PdoMapEntry{0x6077, 0x00, 16}));
  EXPECT_EQ(decode_mapping(0x20010308u), (PdoMapEntry{0x2001, 0x03, 8}));
  EXPECT_TRUE(is_dummy(dummy_entry(DataType::kInteger16)));
  EXPECT_FALSE(is_dummy(map_entry(od::kTargetTorque)));
}

TEST(Pdo, MappingRoundTrip) {
  std::mt19937 rng(7);
  for (int i = 0; i < 1000; ++i) {
    const std::uint32_t v = static_cast<std::uint32_t>(rng());  // mt19937: 32-bit values
    EXPECT_EQ(encode_mapping(decode_mapping(v)), v);
  }
}

TEST(Pdo, ContractLayouts) {
  ASSERT_EQ(kRpdo1Layout.count, 2);
  EXPECT_EQ(encode_mapping(kRpdo1Layout.entries[0]), 0x60400010u);
  EXPECT_EQ(encode_mapping(kRpdo1Layout.entries[1]), 0x60710010u);
  EXPECT_EQ(kRpdo1Layout.bytes(), 4);
  ASSERT_EQ(kTpdo1Layout.count, 2);
  EXPECT_EQ(encode_mapping(kTpdo1Layout.entries[0]), 0x60410010u);
  EXPECT_EQ(encode_mapping(kTpdo1Layout.entries[1]), 0x60640020u);
  EXPECT_EQ(kTpdo1Layout.bytes(), 6);
  ASSERT_EQ(kControlwordRpdoLayout.count, 1);
  EXPECT_EQ(kControlwordRpdoLayout.bytes(), 2);
  EXPECT_EQ(kTpdo1Layout.offset_of(od::kPositionActual), 2);
  EXPECT_EQ(kTpdo1Layout.offset_of(od::kTargetTorque), -1);
}

TEST(Pdo, BroadcastLayouts) {
  // Drive in slot 2 of 4: dummy, dummy, 6071h, dummy.
  const PdoLayout l = broadcast_rpdo_layout(2, 4);
  ASSERT_EQ(l.count, 4);
  EXPECT_EQ(encode_mapping(l.entries[0]), 0x00030010u);
  EXPECT_EQ(encode_mapping(l.entries[1]), 0x00030010u);
  EXPECT_EQ(encode_mapping(l.entries[2]), 0x60710010u);
  EXPECT_EQ(encode_mapping(l.entries[3]), 0x00030010u);
  EXPECT_EQ(l.bytes(), 8);
  EXPECT_EQ(l.offset_of(od::kTargetTorque), 4);
  for (std::uint8_t slot = 0; slot < 4; ++slot) {
    const PdoLayout s = broadcast_rpdo_layout(slot, 4);
    int own = 0;
    for (std::uint8_t i = 0; i < s.count; ++i) own += is_dummy(s.entries[i]) ? 0 : 1;
    EXPECT_EQ(own, 1);
    EXPECT_EQ(s.offset_of(od::kTargetTorque), 2 * slot);
  }
  EXPECT_EQ(broadcast_rpdo_layout(0, 2).bytes(), 4);
  EXPECT_EQ(broadcast_rpdo_layout(0, 5).count, 0);
  EXPECT_EQ(broadcast_rpdo_layout(0, 0).count, 0);
}

TEST(Pdo, BroadcastFeedbackLayouts) {
  // Issue 15: TPDO1 = 6064h alone (4 B), TPDO3 = 6041h alone (2 B).
  ASSERT_EQ(kPositionTpdoLayout.count, 1);
  EXPECT_EQ(encode_mapping(kPositionTpdoLayout.entries[0]), 0x60640020u);
  EXPECT_EQ(kPositionTpdoLayout.bytes(), 4);
  ASSERT_EQ(kStatuswordTpdoLayout.count, 1);
  EXPECT_EQ(encode_mapping(kStatuswordTpdoLayout.entries[0]), 0x60410010u);
  EXPECT_EQ(kStatuswordTpdoLayout.bytes(), 2);
  EXPECT_EQ(kStatuswordTpdoNumber, 3);
}

TEST(Pdo, BroadcastFeedbackGolden) {
  // Node 2, position -2 counts: 182h, FE FF FF FF. Node 4, statusword 0637h: 384h, 37 06.
  EXPECT_EQ(*encode_position_tpdo(2, -2), make_frame(0x182, {0xFE, 0xFF, 0xFF, 0xFF}));
  EXPECT_EQ(*decode_position_tpdo(make_frame(0x183, {0x78, 0x56, 0x34, 0x12})), 0x12345678);
  EXPECT_EQ(*encode_statusword_tpdo(4, 0x0637), make_frame(0x384, {0x37, 0x06}));
  EXPECT_EQ(*decode_statusword_tpdo(make_frame(0x381, {0x08, 0x02})), 0x0208);
  // The per-drive TPDO1 (6 B) is not a position TPDO, nor is a TPDO3 of 4 B a statusword.
  EXPECT_EQ(decode_position_tpdo(make_frame(0x181, {0x37, 0x06, 0, 0, 0, 0})).error(),
            Error::kWrongDlc);
  EXPECT_EQ(decode_statusword_tpdo(make_frame(0x381, {0, 0, 0, 0})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_statusword_tpdo(make_frame(0x181, {0x37, 0x06})).error(), Error::kWrongFunction);
  EXPECT_EQ(encode_statusword_tpdo(0, 0).error(), Error::kBadNodeId);
}

TEST(Pdo, CommunicationParameterValues) {
  // 1800h sub1: bit 31 invalid, bit 30 no RTR, COB-ID.
  EXPECT_EQ(pdo_cob_id_value(0x181, true), 0x40000181u);
  EXPECT_EQ(pdo_cob_id_value(0x181, false), 0xC0000181u);
  EXPECT_EQ(pdo_cob_id_value(0x200, true, true), 0x00000200u);
  EXPECT_EQ(kTransmissionSyncEvery, 1);
  EXPECT_EQ(kTransmissionEventProfile, 0xFF);
}

TEST(Pdo, Rpdo1Golden) {
  // Node 2: controlword 000Fh, target torque -100 per mille (FF9Ch).
  EXPECT_EQ(*encode_rpdo1(2, {0x000F, -100}), make_frame(0x202, {0x0F, 0x00, 0x9C, 0xFF}));
  const Result<DriveCommand> c = decode_rpdo1(make_frame(0x204, {0x06, 0x00, 0xE8, 0x03}));
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->controlword, 0x0006);
  EXPECT_EQ(c->target_torque, 1000);
}

TEST(Pdo, Tpdo1Golden) {
  // Node 1: statusword 0637h, position -2 counts.
  EXPECT_EQ(*encode_tpdo1(1, {0x0637, -2}),
            make_frame(0x181, {0x37, 0x06, 0xFE, 0xFF, 0xFF, 0xFF}));
  const Result<DriveFeedback> f =
      decode_tpdo1(make_frame(0x183, {0x27, 0x02, 0x78, 0x56, 0x34, 0x12}));
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f->statusword, 0x0227);
  EXPECT_EQ(f->position, 0x12345678);
  EXPECT_EQ(*pdo_node(make_frame(0x183, {})), 3);
}

TEST(Pdo, BroadcastGolden) {
  BroadcastTorques t;
  t.torque = {1, -1, 0x1234, -32768};
  t.drives = 4;
  const CanFrame golden = make_frame(0x200, {0x01, 0x00, 0xFF, 0xFF, 0x34, 0x12, 0x00, 0x80});
  EXPECT_EQ(*encode_broadcast_torques(t), golden);
  EXPECT_EQ(*decode_broadcast_torques(golden), t);
  EXPECT_EQ(*decode_broadcast_torque(golden, 0), 1);
  EXPECT_EQ(*decode_broadcast_torque(golden, 1), -1);
  EXPECT_EQ(*decode_broadcast_torque(golden, 2), 0x1234);
  EXPECT_EQ(*decode_broadcast_torque(golden, 3), -32768);
  EXPECT_EQ(*encode_controlword_rpdo(3, 0x008F), make_frame(0x203, {0x8F, 0x00}));
  EXPECT_EQ(*decode_controlword_rpdo(make_frame(0x203, {0x0F, 0x01})), 0x010F);
}

TEST(Pdo, RoundTripsSeeded) {
  std::mt19937 rng(42);
  for (int i = 0; i < 2000; ++i) {
    const auto node = static_cast<std::uint8_t>(1 + rng() % 127);
    const DriveCommand c{static_cast<std::uint16_t>(rng()), static_cast<std::int16_t>(rng())};
    const Result<DriveCommand> dc = decode_rpdo1(*encode_rpdo1(node, c));
    ASSERT_TRUE(dc.ok());
    EXPECT_EQ(*dc, c);
    const DriveFeedback f{static_cast<std::uint16_t>(rng()), static_cast<std::int32_t>(rng())};
    const Result<DriveFeedback> df = decode_tpdo1(*encode_tpdo1(node, f));
    ASSERT_TRUE(df.ok());
    EXPECT_EQ(*df, f);
    BroadcastTorques t;
    t.drives = static_cast<std::uint8_t>(1 + rng() % 4);
    for (std::uint8_t k = 0; k < t.drives; ++k) t.torque[k] = static_cast<std::int16_t>(rng());
    const Result<BroadcastTorques> dt = decode_broadcast_torques(*encode_broadcast_torques(t));
    ASSERT_TRUE(dt.ok());
    EXPECT_EQ(*dt, t);
  }
}

TEST(Pdo, Malformed) {
  EXPECT_EQ(encode_rpdo1(0, {}).error(), Error::kBadNodeId);
  EXPECT_EQ(encode_tpdo1(128, {}).error(), Error::kBadNodeId);
  EXPECT_EQ(decode_rpdo1(make_frame(0x201, {0x0F, 0x00, 0x9C})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_rpdo1(make_frame(0x201, {0x0F, 0x00, 0x9C, 0xFF, 0x00})).error(),
            Error::kWrongDlc);
  EXPECT_EQ(decode_tpdo1(make_frame(0x181, {0x37, 0x06, 0xFE, 0xFF})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_tpdo1(make_frame(0x181, {})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_tpdo1(make_frame(0x281, {0, 0, 0, 0, 0, 0})).error(), Error::kWrongFunction);
  EXPECT_EQ(decode_rpdo1(make_frame(0x181, {0, 0, 0, 0})).error(), Error::kWrongFunction);
  EXPECT_EQ(decode_tpdo1(make_frame(0x180, {0, 0, 0, 0, 0, 0})).error(), Error::kUnknownCobId);
  CanFrame rtr = make_frame(0x181, {});
  rtr.rtr = true;
  EXPECT_EQ(decode_tpdo1(rtr).error(), Error::kRemoteFrame);
  BroadcastTorques t;
  t.drives = 5;
  EXPECT_EQ(encode_broadcast_torques(t).error(), Error::kBadValue);
  t.drives = 0;
  EXPECT_EQ(encode_broadcast_torques(t).error(), Error::kBadValue);
  EXPECT_EQ(decode_broadcast_torques(make_frame(0x200, {1, 2, 3})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_broadcast_torques(make_frame(0x200, {})).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_broadcast_torque(make_frame(0x200, {1, 2, 3, 4}), 2).error(), Error::kWrongDlc);
  EXPECT_EQ(decode_broadcast_torque(make_frame(0x200, {1, 2, 3, 4, 5, 6, 7, 8}), 4).error(),
            Error::kBadValue);
  EXPECT_EQ(decode_controlword_rpdo(make_frame(0x201, {0x0F, 0x00, 0x00, 0x00})).error(),
            Error::kWrongDlc);
  EXPECT_EQ(pdo_node(make_frame(0x701, {})).error(), Error::kWrongFunction);
}

}  // namespace
}  // namespace dualv::fw

namespace dualv::fw {
namespace {

// The CAN FD RPDO mapping of node 2 (slot 1) of four, entry by entry as 0xIIIISSLL (CiA 301
// 7.4.7.1): dummies UNSIGNED16 0006h + INTEGER16 0003h for the others' slices.
TEST(FdPdo, MappingOfSlot1ByHand) {
  const PdoLayout l = fd_rpdo_layout(1, 4);
  ASSERT_EQ(l.count, 8);
  const std::uint32_t want[8] = {0x00060010, 0x00030010, 0x60400010, 0x60710010,
                                 0x00060010, 0x00030010, 0x00060010, 0x00030010};
  for (int i = 0; i < 8; ++i)
    EXPECT_EQ(encode_mapping(l.entries[static_cast<std::size_t>(i)]), want[i]) << i;
  EXPECT_EQ(l.bytes(), 16);
  EXPECT_EQ(l.offset_of(od::kControlword), 4);
  EXPECT_EQ(l.offset_of(od::kTargetTorque), 6);
  EXPECT_EQ(fd_rpdo_bytes(4), 16);
  EXPECT_EQ(fd_rpdo_bytes(3), 12);  // an FD size itself
  EXPECT_EQ(fd_rpdo_layout(0, 5).count, 0);
  EXPECT_EQ(fd_rpdo_layout(0, 0).count, 0);
}

TEST(FdPdo, CommandsFrameByHand) {
  FdCommands c;
  c.drives = 4;
  c.command = {DriveCommand{0x000F, 100}, DriveCommand{0x0006, -100}, DriveCommand{0x0007, 0},
               DriveCommand{0x0080, -32768}};
  const Result<CanFrame> f = encode_fd_commands(c);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->id, 0x200u);
  EXPECT_TRUE(f->fd);
  EXPECT_TRUE(f->brs);
  EXPECT_EQ(f->dlc, 16);
  const std::uint8_t want[16] = {0x0F, 0x00, 0x64, 0x00, 0x06, 0x00, 0x9C, 0xFF,
                                 0x07, 0x00, 0x00, 0x00, 0x80, 0x00, 0x00, 0x80};
  for (int i = 0; i < 16; ++i) EXPECT_EQ(f->data[static_cast<std::size_t>(i)], want[i]) << i;
  for (std::size_t i = 16; i < f->data.size(); ++i) EXPECT_EQ(f->data[i], 0) << i;
  const Result<FdCommands> back = decode_fd_commands(*f, 4);
  ASSERT_TRUE(back);
  EXPECT_EQ(*back, c);
  const Result<DriveCommand> slot1 = decode_fd_command(*f, 1);
  ASSERT_TRUE(slot1);
  EXPECT_EQ(slot1->controlword, 0x0006);
  EXPECT_EQ(slot1->target_torque, -100);
}

TEST(FdPdo, ThreeDrivesTakeTheTwelveByteSize) {
  FdCommands c;
  c.drives = 3;
  c.command[2] = {0x000F, 1};
  const Result<CanFrame> f = encode_fd_commands(c);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->dlc, 12);
  EXPECT_EQ(f->data[8], 0x0F);
  EXPECT_EQ(f->data[10], 1);
  EXPECT_FALSE(decode_fd_command(*f, 3));  // no slot 3 in 12 bytes
}

TEST(FdPdo, RefusesWhatIsNotTheLayout) {
  FdCommands none;
  EXPECT_EQ(encode_fd_commands(none).error(), Error::kBadValue);
  none.drives = 5;
  EXPECT_EQ(encode_fd_commands(none).error(), Error::kBadValue);
  // The classic broadcast frame on the same COB-ID is not an FD RPDO.
  BroadcastTorques t;
  t.drives = 4;
  const Result<CanFrame> classic = encode_broadcast_torques(t);
  ASSERT_TRUE(classic);
  EXPECT_EQ(decode_fd_command(*classic, 0).error(), Error::kWrongDlc);
  CanFrame other = data_frame(0x201, 16, true);
  EXPECT_EQ(decode_fd_command(other, 0).error(), Error::kWrongFunction);
}

TEST(FdPdo, Tpdo1AsFdFrameByHand) {
  const Result<CanFrame> f = encode_fd_tpdo1(3, DriveFeedback{0x0637, -2});
  ASSERT_TRUE(f);
  EXPECT_EQ(f->id, 0x183u);
  EXPECT_TRUE(f->fd && f->brs);
  EXPECT_EQ(f->dlc, 6);
  const std::uint8_t want[6] = {0x37, 0x06, 0xFE, 0xFF, 0xFF, 0xFF};
  for (int i = 0; i < 6; ++i) EXPECT_EQ(f->data[static_cast<std::size_t>(i)], want[i]) << i;
  const Result<DriveFeedback> back = decode_tpdo1(*f);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->position, -2);
}

TEST(BusLayoutEnum, NamesAreTheConfigValues) {
  EXPECT_STREQ(to_string(BusLayout::kPerDrive), "per_drive");
  EXPECT_STREQ(to_string(BusLayout::kBroadcast), "broadcast");
  EXPECT_STREQ(to_string(BusLayout::kFd), "fd");
}

}  // namespace
}  // namespace dualv::fw
