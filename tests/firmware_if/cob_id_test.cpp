#include "firmware_if/cob_id.hpp"

#include <gtest/gtest.h>

#include "frame_builder.hpp"

namespace dualv::fw {
namespace {

TEST(CobId, NodeIdRange) {
  EXPECT_FALSE(is_valid_node_id(0));
  EXPECT_TRUE(is_valid_node_id(1));
  EXPECT_TRUE(is_valid_node_id(127));
  EXPECT_FALSE(is_valid_node_id(128));
  EXPECT_FALSE(is_valid_node_id(255));
}

// CiA 301 7.3.5 predefined connection set, written out.
TEST(CobId, PredefinedConnectionSetForNode3) {
  EXPECT_EQ(cob_id(Function::kNmt, 3), 0x000);
  EXPECT_EQ(cob_id(Function::kSync, 3), 0x080);
  EXPECT_EQ(cob_id(Function::kEmcy, 3), 0x083);
  EXPECT_EQ(cob_id(Function::kTime, 3), 0x100);
  EXPECT_EQ(cob_id(Function::kTpdo1, 3), 0x183);
  EXPECT_EQ(cob_id(Function::kRpdo1, 3), 0x203);
  EXPECT_EQ(cob_id(Function::kTpdo2, 3), 0x283);
  EXPECT_EQ(cob_id(Function::kRpdo2, 3), 0x303);
  EXPECT_EQ(cob_id(Function::kTpdo3, 3), 0x383);
  EXPECT_EQ(cob_id(Function::kRpdo3, 3), 0x403);
  EXPECT_EQ(cob_id(Function::kTpdo4, 3), 0x483);
  EXPECT_EQ(cob_id(Function::kRpdo4, 3), 0x503);
  EXPECT_EQ(cob_id(Function::kSdoTx, 3), 0x583);
  EXPECT_EQ(cob_id(Function::kSdoRx, 3), 0x603);
  EXPECT_EQ(cob_id(Function::kHeartbeat, 3), 0x703);
  EXPECT_EQ(cob_id(Function::kBroadcastRpdo, 3), 0x200);
  EXPECT_EQ(tpdo_function(2), Function::kTpdo2);
  EXPECT_EQ(rpdo_function(4), Function::kRpdo4);
}

TEST(CobId, MakeCobIdChecksNode) {
  EXPECT_EQ(make_cob_id(Function::kEmcy, 0).error(), Error::kBadNodeId);
  EXPECT_EQ(make_cob_id(Function::kEmcy, 128).error(), Error::kBadNodeId);
  EXPECT_EQ(*make_cob_id(Function::kEmcy, 127), 0x0FF);
  EXPECT_EQ(*make_cob_id(Function::kSync, 0), 0x080);  // no node, none needed
}

TEST(CobId, ClassifyGolden) {
  struct Case {
    std::uint32_t id;
    Function f;
    std::uint8_t node;
  };
  const Case cases[] = {
      {0x000, Function::kNmt, 0},       {0x080, Function::kSync, 0},
      {0x081, Function::kEmcy, 1},      {0x0FF, Function::kEmcy, 127},
      {0x100, Function::kTime, 0},      {0x184, Function::kTpdo1, 4},
      {0x201, Function::kRpdo1, 1},     {0x200, Function::kBroadcastRpdo, 0},
      {0x2A0, Function::kTpdo2, 0x20},  {0x302, Function::kRpdo2, 2},
      {0x3FF, Function::kTpdo3, 127},   {0x401, Function::kRpdo3, 1},
      {0x481, Function::kTpdo4, 1},     {0x57F, Function::kRpdo4, 127},
      {0x582, Function::kSdoTx, 2},     {0x602, Function::kSdoRx, 2},
      {0x701, Function::kHeartbeat, 1}, {0x77F, Function::kHeartbeat, 127},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.id);
    const Result<CobIdInfo> r = classify(c.id);
    ASSERT_TRUE(r.ok()) << r.error();
    EXPECT_EQ(r->function, c.f);
    EXPECT_EQ(r->node, c.node);
  }
}

TEST(CobId, ClassifyUnknown) {
  // NMT with a "node", TIME + node, node 0 of per-node functions, unused 680h block,
  // LSS 7E4h/7E5h, out of the 11-bit range.
  for (std::uint32_t id : {0x001u, 0x07Fu, 0x101u, 0x180u, 0x280u, 0x580u, 0x600u, 0x680u, 0x6FFu,
                           0x700u, 0x780u, 0x7E4u, 0x7E5u, 0x7FFu, 0x800u, 0x1FFFFFFFu}) {
    EXPECT_EQ(classify(id).error(), Error::kUnknownCobId) << std::hex << id;
  }
}

TEST(CobId, ExhaustiveRoundTrip) {
  // Every standard id either classifies and maps back to itself, or is unknown.
  int known = 0;
  for (std::uint32_t id = 0; id <= 0x7FF; ++id) {
    const Result<CobIdInfo> r = classify(id);
    if (!r) {
      EXPECT_EQ(r.error(), Error::kUnknownCobId);
      continue;
    }
    ++known;
    EXPECT_EQ(cob_id(r->function, r->node), id) << std::hex << id;
  }
  // NMT, SYNC, TIME, broadcast + 12 per-node functions x 127 nodes.
  EXPECT_EQ(known, 4 + 12 * 127);
}

TEST(CobId, FrameChecks) {
  CanFrame f = test::make_frame(0x701, {0x05});
  EXPECT_TRUE(classify(f).ok());
  f.extended = true;
  EXPECT_EQ(classify(f).error(), Error::kExtendedId);
  f.extended = false;
  EXPECT_EQ(*expect_function(f, Function::kHeartbeat), 1);
  EXPECT_EQ(expect_function(f, Function::kEmcy).error(), Error::kWrongFunction);
  f.rtr = true;
  EXPECT_EQ(expect_function(f, Function::kHeartbeat).error(), Error::kRemoteFrame);
}

}  // namespace
}  // namespace dualv::fw
