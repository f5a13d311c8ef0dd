// Every firmware_if codec runs inside the real-time cycle: none may allocate (STYLE.md).
// The test binary replaces the global operator new with a counting one
// (tests/support/allocation_counter.cpp) and runs each encoder and decoder between two readings of
// the counter.
#include <gtest/gtest.h>

#include <array>

#include "firmware_if/cia402.hpp"
#include "firmware_if/emcy.hpp"
#include "firmware_if/heartbeat.hpp"
#include "firmware_if/nmt.hpp"
#include "firmware_if/pdo.hpp"
#include "firmware_if/sdo.hpp"
#include "firmware_if/sync.hpp"
#include "tests/support/allocation_counter.hpp"

namespace dualv::fw {
namespace {

TEST(NoAllocation, CounterWorks) {
  const long before = dualv::test::allocation_count();
  auto* p = new int(3);
  EXPECT_EQ(dualv::test::allocation_count() - before, 1);
  delete p;
}

TEST(NoAllocation, EveryCodec) {
  std::array<std::uint8_t, 64> buffer{};
  const std::array<std::uint8_t, 20> payload{};
  const long before = dualv::test::allocation_count();
  int ok = 0;
  for (int i = 0; i < 100; ++i) {
    ok += decode_nmt(*encode_nmt(NmtCommand::kStart, 3)).ok();
    ok += decode_sync(*encode_sync(5)).ok();
    ok += decode_heartbeat(*encode_heartbeat(3, NmtState::kOperational)).ok();
    Emcy e;
    e.node = 2;
    e.error_code = 0x3210;
    ok += decode_emcy(*encode_emcy(e)).ok();
    ok += emcy_text(0x3211)[0] != 0;
    ok += decode_rpdo1(*encode_rpdo1(1, {0x0F, 100})).ok();
    ok += decode_tpdo1(*encode_tpdo1(1, {0x0237, -5})).ok();
    BroadcastTorques t;
    t.drives = 4;
    ok += decode_broadcast_torques(*encode_broadcast_torques(t)).ok();
    ok += decode_broadcast_torque(*encode_broadcast_torques(t), 3).ok();
    ok += decode_sdo_request(*sdo_download_value(1, od::kMaxTorque, 500)).ok();
    ok += decode_sdo_response(*sdo_upload_value_response(1, od::kStatusword, 0x237), 1).ok();
    ok += decode_sdo_response(*sdo_abort(1, SdoRole::kServer, 0x6072, 0, 0x06090031u)).ok();
    ok += sdo_abort_text(0x06090031u)[0] != 0;
    SdoSegmentSender sender;
    sender.begin(payload);
    SdoSegmentReceiver receiver(buffer);
    receiver.begin(static_cast<std::uint32_t>(payload.size()));
    while (!sender.done()) {
      const SdoSegmentSender::Segment s = sender.next();
      ok += receiver.accept(*decode_sdo_request(
                *sdo_download_segment(1, s.toggle, s.bytes, s.last))) == Error::kNone;
    }
    ok += decode_statusword(0x0237).ok();
    ok += next_transition(Cia402State::kFault, Cia402State::kOperationEnabled).has_value();
  }
  EXPECT_EQ(dualv::test::allocation_count() - before, 0);
  EXPECT_EQ(ok, 100 * 18);  // 15 single calls + 3 segments (20 bytes) per iteration
}

}  // namespace
}  // namespace dualv::fw
