// SdoClient: golden request frames, timeout at exactly T - 1 / T, abort text, segmented
// download and upload against the scripted fake slave, protocol errors.
#include "drivers/canopen/sdo_client.hpp"

#include <gtest/gtest.h>

#include <string>

#include "fake_slave.hpp"

namespace dualv::drivers::canopen {
namespace {

using test::FakeSlave;
using test::to_text;

constexpr std::uint64_t kTimeout = 100'000'000;

struct SdoFixture : ::testing::Test {
  InProcessHub hub{3};
  InProcessBus& master = hub.endpoint(0);
  InProcessBus& sniffer = hub.endpoint(2);
  FakeSlave slave{hub.endpoint(1), 5};
  SdoClient client{5, kTimeout};

  // Lets the slave answer, then hands its frames to the client.
  void exchange(std::uint64_t now) {
    slave.step();
    fw::CanFrame f;
    while (master.receive(f) == BusStatus::kOk) client.on_frame(master, f, now);
  }
};

TEST_F(SdoFixture, ExpeditedWriteGoldenFrames) {
  const std::uint8_t v[] = {0x0A};
  ASSERT_EQ(client.download(master, 0x6060, 0, v, 0), SdoStatus::kBusy);
  exchange(1000);
  EXPECT_EQ(client.status(), SdoStatus::kDone);
  const auto wire = test::drain(sniffer);
  ASSERT_EQ(wire.size(), 2u);
  EXPECT_EQ(to_text(wire[0]), "605#2F6060000A000000");  // CiA 301 7.2.4.3.3: 2Fh = 1 byte
  EXPECT_EQ(to_text(wire[1]), "585#6060600000000000");
  EXPECT_EQ(slave.get(fw::od::kModesOfOperation), 10u);
}

TEST_F(SdoFixture, ExpeditedReadGoldenFrames) {
  std::array<std::uint8_t, 4> buf{};
  ASSERT_EQ(client.upload(master, 0x6076, 0, buf, 0), SdoStatus::kBusy);
  exchange(1000);
  ASSERT_EQ(client.status(), SdoStatus::kDone);
  ASSERT_EQ(client.uploaded().size(), 4u);
  EXPECT_EQ(fw::get_u32_le(buf.data()), 50000u);
  const auto wire = test::drain(sniffer);
  ASSERT_EQ(wire.size(), 2u);
  EXPECT_EQ(to_text(wire[0]), "605#4076600000000000");
  EXPECT_EQ(to_text(wire[1]), "585#4376600050C30000");  // 43h: 4 bytes, 50000 = C350h
}

TEST_F(SdoFixture, TimeoutAtExactlyT) {
  slave.answers_sdo = false;
  std::array<std::uint8_t, 4> buf{};
  ASSERT_EQ(client.upload(master, 0x1000, 0, buf, 1'000), SdoStatus::kBusy);
  exchange(2'000);
  EXPECT_EQ(client.poll(master, 1'000 + kTimeout - 1), SdoStatus::kBusy);
  EXPECT_EQ(test::drain(sniffer).size(), 1u);  // only the request
  EXPECT_EQ(client.poll(master, 1'000 + kTimeout), SdoStatus::kTimeout);
  EXPECT_EQ(client.abort_code(), 0x05040000u);
  EXPECT_STREQ(client.abort_text(), "SDO protocol timed out");
  const auto wire = test::drain(sniffer);
  ASSERT_EQ(wire.size(), 1u);
  EXPECT_EQ(to_text(wire[0]), "605#8000100000000405");  // client abort, 05040000h
}

TEST_F(SdoFixture, TimeoutRestartsWithEverySegment) {
  // A segmented upload whose second segment never comes: the timeout counts from the
  // last request, not from the start of the transfer.
  slave.od[{0x1008, 0}] = {'D', 'u', 'a', 'l', '-', 'V', ' ', 'd', 'r', 'i', 'v', 'e'};
  std::array<std::uint8_t, 32> buf{};
  ASSERT_EQ(client.upload(master, 0x1008, 0, buf, 0), SdoStatus::kBusy);
  exchange(50'000'000);  // initiate answered at 50 ms -> first segment request sent at 50 ms
  slave.answers_sdo = false;
  exchange(60'000'000);
  EXPECT_EQ(client.poll(master, 50'000'000 + kTimeout - 1), SdoStatus::kBusy);
  EXPECT_EQ(client.poll(master, 50'000'000 + kTimeout), SdoStatus::kTimeout);
}

TEST_F(SdoFixture, AbortGivesReadableText) {
  slave.abort_on_write[{0x6060, 0}] = static_cast<std::uint32_t>(fw::SdoAbortCode::kInvalidValue);
  const std::uint8_t v[] = {0x0B};
  client.download(master, 0x6060, 0, v, 0);
  exchange(1000);
  EXPECT_EQ(client.status(), SdoStatus::kAborted);
  EXPECT_EQ(client.abort_code(), 0x06090030u);
  EXPECT_STREQ(client.abort_text(), "invalid value for parameter (download only)");
}

TEST_F(SdoFixture, ReadOfMissingObjectAborts) {
  std::array<std::uint8_t, 4> buf{};
  client.upload(master, 0x2345, 7, buf, 0);
  exchange(1000);
  EXPECT_EQ(client.status(), SdoStatus::kAborted);
  EXPECT_STREQ(client.abort_text(), "object does not exist in the object dictionary");
}

TEST_F(SdoFixture, SegmentedDownload) {
  const std::vector<std::uint8_t> data = {1,  2,  3,  4,  5,  6,  7,  8, 9,
                                          10, 11, 12, 13, 14, 15, 16, 17};
  ASSERT_EQ(client.download(master, 0x2000, 1, data, 0), SdoStatus::kBusy);
  for (int i = 0; i < 10 && client.busy(); ++i) exchange(1000);
  ASSERT_EQ(client.status(), SdoStatus::kDone);
  EXPECT_EQ((slave.od[{0x2000, 1}]), data);
  const auto wire = test::drain(sniffer);
  ASSERT_EQ(wire.size(), 8u);                           // initiate + 3 segments, each answered
  EXPECT_EQ(to_text(wire[0]), "605#2100200111000000");  // 21h: segmented, size 17
  EXPECT_EQ(to_text(wire[2]), "605#0001020304050607");  // toggle 0, 7 bytes
  EXPECT_EQ(to_text(wire[3]), "585#2000000000000000");
  EXPECT_EQ(to_text(wire[4]), "605#1008090A0B0C0D0E");  // toggle 1
  EXPECT_EQ(to_text(wire[6]),
            "605#090F101100000000");  // toggle 0, 3 bytes (n = 4 in bits 3..1), c = 1
}

TEST_F(SdoFixture, SegmentedUpload) {
  const std::vector<std::uint8_t> name = {'E', 'T', 'E', 'L', ' ', 'D', 'S', 'C', '2', 'P'};
  slave.od[{0x1008, 0}] = name;
  std::array<std::uint8_t, 32> buf{};
  ASSERT_EQ(client.upload(master, 0x1008, 0, buf, 0), SdoStatus::kBusy);
  for (int i = 0; i < 10 && client.busy(); ++i) exchange(1000);
  ASSERT_EQ(client.status(), SdoStatus::kDone);
  EXPECT_EQ(std::vector<std::uint8_t>(client.uploaded().begin(), client.uploaded().end()), name);
}

TEST_F(SdoFixture, SegmentedUploadTooBigForBufferAborts) {
  slave.od[{0x1008, 0}] = std::vector<std::uint8_t>(20, 'x');
  std::array<std::uint8_t, 8> buf{};
  client.upload(master, 0x1008, 0, buf, 0);
  exchange(1000);
  EXPECT_EQ(client.status(), SdoStatus::kError);
  EXPECT_EQ(client.abort_code(), 0x06070012u);
  slave.step();
  ASSERT_EQ(slave.aborts_received.size(), 1u);
}

TEST_F(SdoFixture, WrongToggleFromServerAborts) {
  // Hand-made server answers: a download segment response with the wrong toggle.
  const std::vector<std::uint8_t> data(10, 0x55);
  client.download(master, 0x2000, 0, data, 0);
  fw::CanFrame f = *fw::sdo_download_initiate_response(5, 0x2000, 0);
  client.on_frame(master, f, 1);
  f = *fw::sdo_download_segment_response(5, true);  // first segment has toggle 0
  client.on_frame(master, f, 2);
  EXPECT_EQ(client.status(), SdoStatus::kError);
  EXPECT_EQ(client.protocol_error(), fw::Error::kToggleMismatch);
  EXPECT_EQ(client.abort_code(), 0x05030000u);
}

TEST_F(SdoFixture, IgnoresOtherNodesAndCountsStrayResponses) {
  fw::CanFrame other = *fw::sdo_download_initiate_response(6, 0x2000, 0);
  EXPECT_FALSE(client.on_frame(master, other, 0));
  fw::CanFrame stray = *fw::sdo_download_initiate_response(5, 0x2000, 0);
  EXPECT_TRUE(client.on_frame(master, stray, 0));
  EXPECT_EQ(client.unexpected(), 1u);
  EXPECT_EQ(client.status(), SdoStatus::kIdle);
}

TEST_F(SdoFixture, BusyClientRefusesASecondTransfer) {
  std::array<std::uint8_t, 4> buf{};
  client.upload(master, 0x1000, 0, buf, 0);
  EXPECT_EQ(client.upload(master, 0x1001, 0, buf, 0), SdoStatus::kError);
  EXPECT_EQ(client.index(), 0x1000);
  client.cancel(master);
  EXPECT_EQ(client.status(), SdoStatus::kIdle);
}

}  // namespace
}  // namespace dualv::drivers::canopen
