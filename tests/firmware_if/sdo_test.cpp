#include "firmware_if/sdo.hpp"

#include <gtest/gtest.h>

#include <array>
#include <numeric>
#include <string>
#include <vector>

#include "frame_builder.hpp"

namespace dualv::fw {
namespace {

using test::make_frame;

// ---- golden frames, client side (600h + node) -----------------------------------------

TEST(Sdo, ExpeditedDownloadFourBytes) {
  // 23h = ccs 1, n 0, e 1, s 1: four data bytes. 6076h:00 rated torque = 0x00012345 mN m.
  const std::uint8_t v[] = {0x45, 0x23, 0x01, 0x00};
  EXPECT_EQ(*sdo_download_expedited(3, 0x6076, 0x00, v),
            make_frame(0x603, {0x23, 0x76, 0x60, 0x00, 0x45, 0x23, 0x01, 0x00}));
  EXPECT_EQ(*sdo_download_value(3, od::kRatedTorque, 0x00012345u),
            make_frame(0x603, {0x23, 0x76, 0x60, 0x00, 0x45, 0x23, 0x01, 0x00}));
  // Four raw bytes to 6072h:00, as in the example.
  const std::uint8_t w[] = {0xE8, 0x03, 0x00, 0x00};
  EXPECT_EQ(*sdo_download_expedited(1, 0x6072, 0x00, w),
            make_frame(0x601, {0x23, 0x72, 0x60, 0x00, 0xE8, 0x03, 0x00, 0x00}));
}

TEST(Sdo, ExpeditedDownloadSizedByEntry) {
  // 6072h max torque is u16: 2Bh (n = 2), value 500 per mille = F4h 01h.
  EXPECT_EQ(*sdo_download_value(2, od::kMaxTorque, 500),
            make_frame(0x602, {0x2B, 0x72, 0x60, 0x00, 0xF4, 0x01, 0x00, 0x00}));
  // 6060h modes of operation is i8: 2Fh (n = 3), mode 10 (CST).
  EXPECT_EQ(*sdo_download_value(4, od::kModesOfOperation, 10),
            make_frame(0x604, {0x2F, 0x60, 0x60, 0x00, 0x0A, 0x00, 0x00, 0x00}));
  // 605Ah quick stop option i16 = -1 (manufacturer specific): FFh FFh.
  EXPECT_EQ(*sdo_download_value(4, od::kQuickStopOption, static_cast<std::uint32_t>(-1)),
            make_frame(0x604, {0x2B, 0x5A, 0x60, 0x00, 0xFF, 0xFF, 0x00, 0x00}));
  // Three bytes: 27h.
  const std::uint8_t three[] = {1, 2, 3};
  EXPECT_EQ(*sdo_download_expedited(1, 0x2000, 0x05, three),
            make_frame(0x601, {0x27, 0x00, 0x20, 0x05, 0x01, 0x02, 0x03, 0x00}));
}

TEST(Sdo, UploadInitiateAndSegmentRequests) {
  EXPECT_EQ(*sdo_upload_initiate(1, 0x6041, 0x00),
            make_frame(0x601, {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(*sdo_upload_initiate(5, 0x1018, 0x01),
            make_frame(0x605, {0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(*sdo_upload_segment_request(1, false), make_frame(0x601, {0x60, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(*sdo_upload_segment_request(1, true), make_frame(0x601, {0x70, 0, 0, 0, 0, 0, 0, 0}));
}

TEST(Sdo, SegmentedDownloadFrames) {
  // Initiate: 21h (e 0, s 1), size 10 in bytes 4..7.
  EXPECT_EQ(*sdo_download_initiate(1, 0x1008, 0x00, 10),
            make_frame(0x601, {0x21, 0x08, 0x10, 0x00, 0x0A, 0x00, 0x00, 0x00}));
  // Segment 1: t 0, n 0, c 0, 7 bytes.
  const std::uint8_t seven[] = {'d', 'u', 'a', 'l', 'v', '-', 'd'};
  EXPECT_EQ(*sdo_download_segment(1, false, seven, false),
            make_frame(0x601, {0x00, 'd', 'u', 'a', 'l', 'v', '-', 'd'}));
  // Segment 2: t 1 (10h), n 4 (08h), c 1 (01h) = 19h, 3 bytes.
  const std::uint8_t three[] = {'r', 'v', '1'};
  EXPECT_EQ(*sdo_download_segment(1, true, three, true),
            make_frame(0x601, {0x19, 'r', 'v', '1', 0, 0, 0, 0}));
}

TEST(Sdo, AbortFrames) {
  // 80h, index, subindex, abort code LE: 06090031h value too high.
  EXPECT_EQ(*sdo_abort(3, SdoRole::kServer, 0x6072, 0x00, SdoAbortCode::kValueTooHigh),
            make_frame(0x583, {0x80, 0x72, 0x60, 0x00, 0x31, 0x00, 0x09, 0x06}));
  // Client abort on toggle error 05030000h.
  EXPECT_EQ(*sdo_abort(3, SdoRole::kClient, 0x1008, 0x00, SdoAbortCode::kToggleNotAlternated),
            make_frame(0x603, {0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x03, 0x05}));
  const Result<SdoMessage> m =
      decode_sdo_response(make_frame(0x582, {0x80, 0x00, 0x20, 0x01, 0x00, 0x00, 0x02, 0x06}));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->type, SdoType::kAbort);
  EXPECT_EQ(m->node, 2);
  EXPECT_EQ(m->index, 0x2000);
  EXPECT_EQ(m->subindex, 1);
  EXPECT_EQ(m->abort_code, 0x06020000u);
  EXPECT_EQ(std::string(sdo_abort_text(m->abort_code)),
            "object does not exist in the object dictionary");
}

// ---- golden frames, server side (580h + node) ------------------------------------------

TEST(Sdo, ServerResponses) {
  EXPECT_EQ(*sdo_download_initiate_response(3, 0x6072, 0x00),
            make_frame(0x583, {0x60, 0x72, 0x60, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(*sdo_download_segment_response(3, false),
            make_frame(0x583, {0x20, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(*sdo_download_segment_response(3, true),
            make_frame(0x583, {0x30, 0, 0, 0, 0, 0, 0, 0}));
  // Statusword 0237h: 4Bh (scs 2, n 2, e, s).
  EXPECT_EQ(*sdo_upload_value_response(1, od::kStatusword, 0x0237),
            make_frame(0x581, {0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0x00, 0x00}));
  // Device type 00020192h (CiA 402, servo): 43h.
  EXPECT_EQ(*sdo_upload_value_response(1, od::kDeviceType, 0x00020192u),
            make_frame(0x581, {0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00}));
  // Segmented upload: 41h + size 12.
  EXPECT_EQ(*sdo_upload_initiate_response(1, 0x1008, 0x00, 12),
            make_frame(0x581, {0x41, 0x08, 0x10, 0x00, 0x0C, 0x00, 0x00, 0x00}));
  const std::uint8_t five[] = {1, 2, 3, 4, 5};
  // t 1, n 2 (04h), c 1: 15h.
  EXPECT_EQ(*sdo_upload_segment_response(1, true, five, true),
            make_frame(0x581, {0x15, 1, 2, 3, 4, 5, 0, 0}));
}

// ---- decoding golden frames -------------------------------------------------------------

TEST(Sdo, DecodeExpeditedUploadResponse) {
  const Result<SdoMessage> m =
      decode_sdo_response(make_frame(0x581, {0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0xAA, 0xBB}));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->type, SdoType::kUploadInitiate);
  EXPECT_TRUE(m->expedited);
  EXPECT_TRUE(m->size_indicated);
  EXPECT_EQ(m->index, 0x6041);
  EXPECT_EQ(m->subindex, 0);
  EXPECT_EQ(m->data_len, 2);
  EXPECT_EQ(m->value(), 0x0237u);  // bytes past n are not data
}

TEST(Sdo, DecodeExpeditedWithoutSize) {
  // 42h: e 1, s 0: size not indicated, all four bytes delivered.
  const Result<SdoMessage> m =
      decode_sdo_response(make_frame(0x581, {0x42, 0x64, 0x60, 0x00, 0x01, 0x02, 0x03, 0x04}));
  ASSERT_TRUE(m.ok());
  EXPECT_TRUE(m->expedited);
  EXPECT_FALSE(m->size_indicated);
  EXPECT_EQ(m->data_len, 4);
  EXPECT_EQ(m->value(), 0x04030201u);
}

TEST(Sdo, DecodeRequests) {
  Result<SdoMessage> m =
      decode_sdo_request(make_frame(0x603, {0x2B, 0x72, 0x60, 0x00, 0xF4, 0x01, 0x00, 0x00}));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->type, SdoType::kDownloadInitiate);
  EXPECT_EQ(m->node, 3);
  EXPECT_EQ(m->index, 0x6072);
  EXPECT_EQ(m->data_len, 2);
  EXPECT_EQ(m->value(), 500u);

  m = decode_sdo_request(make_frame(0x603, {0x21, 0x08, 0x10, 0x00, 0x0A, 0x00, 0x00, 0x00}));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->type, SdoType::kDownloadInitiate);
  EXPECT_FALSE(m->expedited);
  EXPECT_TRUE(m->size_indicated);
  EXPECT_EQ(m->size, 10u);

  m = decode_sdo_request(make_frame(0x603, {0x19, 'r', 'v', '1', 0, 0, 0, 0}));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->type, SdoType::kDownloadSegment);
  EXPECT_TRUE(m->toggle);
  EXPECT_TRUE(m->last);
  EXPECT_EQ(m->data_len, 3);
  EXPECT_EQ(m->data[0], 'r');
  EXPECT_EQ(m->data[2], '1');

  m = decode_sdo_request(make_frame(0x603, {0x70, 0, 0, 0, 0, 0, 0, 0}));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->type, SdoType::kUploadSegment);
  EXPECT_TRUE(m->toggle);

  m = decode_sdo_request(make_frame(0x603, {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->type, SdoType::kUploadInitiate);
  EXPECT_EQ(m->index, 0x6041);
}

// ---- malformed --------------------------------------------------------------------------

TEST(Sdo, BadCommandSpecifier) {
  // cs 5 and 6 are block transfer (unsupported), 7 is undefined: both directions.
  for (const std::uint8_t b0 :
       std::initializer_list<std::uint8_t>{0xA0, 0xA4, 0xC0, 0xC6, 0xE0, 0xFF}) {
    EXPECT_EQ(decode_sdo_request(make_frame(0x601, {b0, 0, 0, 0, 0, 0, 0, 0})).error(),
              Error::kBadCommandSpecifier)
        << int(b0);
    EXPECT_EQ(decode_sdo_response(make_frame(0x581, {b0, 0, 0, 0, 0, 0, 0, 0})).error(),
              Error::kBadCommandSpecifier)
        << int(b0);
  }
}

TEST(Sdo, WrongDlcFunctionAndNode) {
  EXPECT_EQ(decode_sdo_request(make_frame(0x601, {0x40, 0x41, 0x60, 0x00})).error(),
            Error::kWrongDlc);
  EXPECT_EQ(
      decode_sdo_response(make_frame(0x581, {0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0x00})).error(),
      Error::kWrongDlc);
  EXPECT_EQ(decode_sdo_response(make_frame(0x581, {})).error(), Error::kWrongDlc);
  // A request is not a response and vice versa.
  EXPECT_EQ(decode_sdo_response(make_frame(0x601, {0x40, 0, 0, 0, 0, 0, 0, 0})).error(),
            Error::kWrongFunction);
  EXPECT_EQ(decode_sdo_request(make_frame(0x581, {0x43, 0, 0, 0, 0, 0, 0, 0})).error(),
            Error::kWrongFunction);
  EXPECT_EQ(decode_sdo_request(make_frame(0x600, {0x40, 0, 0, 0, 0, 0, 0, 0})).error(),
            Error::kUnknownCobId);
  const CanFrame from2 = make_frame(0x582, {0x60, 0x72, 0x60, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(decode_sdo_response(from2, 3).error(), Error::kWrongNode);
  EXPECT_TRUE(decode_sdo_response(from2, 2).ok());
}

TEST(Sdo, EncoderRejectsBadArguments) {
  const std::uint8_t five[] = {1, 2, 3, 4, 5};
  const std::uint8_t eight[] = {1, 2, 3, 4, 5, 6, 7, 8};
  EXPECT_EQ(sdo_download_expedited(1, 0x6072, 0, five).error(), Error::kTooLong);
  EXPECT_EQ(sdo_download_expedited(1, 0x6072, 0, {}).error(), Error::kTooLong);
  EXPECT_EQ(sdo_download_segment(1, false, eight, true).error(), Error::kTooLong);
  EXPECT_EQ(sdo_upload_initiate(0, 0x6041, 0).error(), Error::kBadNodeId);
  EXPECT_EQ(sdo_upload_initiate(128, 0x6041, 0).error(), Error::kBadNodeId);
  EXPECT_EQ(sdo_abort(0, SdoRole::kServer, 0, 0, 0u).error(), Error::kBadNodeId);
}

// ---- round trips ------------------------------------------------------------------------

TEST(Sdo, ExpeditedRoundTripAllSizes) {
  const std::array<std::uint8_t, 4> src{0xDE, 0xAD, 0xBE, 0xEF};
  for (std::size_t n = 1; n <= 4; ++n) {
    const auto bytes = std::span<const std::uint8_t>(src).first(n);
    const Result<SdoMessage> req =
        decode_sdo_request(*sdo_download_expedited(7, 0x2001, 0x03, bytes));
    ASSERT_TRUE(req.ok());
    EXPECT_EQ(req->type, SdoType::kDownloadInitiate);
    EXPECT_EQ(req->index, 0x2001);
    EXPECT_EQ(req->subindex, 3);
    ASSERT_EQ(req->data_len, n);
    EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), req->data.begin()));
    const Result<SdoMessage> resp =
        decode_sdo_response(*sdo_upload_expedited_response(7, 0x2001, 0x03, bytes));
    ASSERT_TRUE(resp.ok());
    EXPECT_EQ(resp->type, SdoType::kUploadInitiate);
    ASSERT_EQ(resp->data_len, n);
    EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), resp->data.begin()));
  }
}

TEST(Sdo, SegmentRoundTripAllSizes) {
  const std::array<std::uint8_t, 7> src{1, 2, 3, 4, 5, 6, 7};
  for (std::size_t n = 0; n <= 7; ++n) {
    for (bool toggle : {false, true}) {
      for (bool last : {false, true}) {
        const auto bytes = std::span<const std::uint8_t>(src).first(n);
        const Result<SdoMessage> d =
            decode_sdo_request(*sdo_download_segment(9, toggle, bytes, last));
        ASSERT_TRUE(d.ok());
        EXPECT_EQ(d->type, SdoType::kDownloadSegment);
        EXPECT_EQ(d->toggle, toggle);
        EXPECT_EQ(d->last, last);
        ASSERT_EQ(d->data_len, n);
        const Result<SdoMessage> u =
            decode_sdo_response(*sdo_upload_segment_response(9, toggle, bytes, last));
        ASSERT_TRUE(u.ok());
        EXPECT_EQ(u->type, SdoType::kUploadSegment);
        EXPECT_EQ(u->toggle, toggle);
        EXPECT_EQ(u->last, last);
        ASSERT_EQ(u->data_len, n);
        EXPECT_TRUE(std::equal(bytes.begin(), bytes.end(), u->data.begin()));
      }
    }
  }
}

TEST(Sdo, OtherMessagesRoundTrip) {
  Result<SdoMessage> m = decode_sdo_response(*sdo_download_initiate_response(5, 0x1017, 0));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->type, SdoType::kDownloadInitiate);
  EXPECT_EQ(m->index, 0x1017);
  m = decode_sdo_response(*sdo_download_segment_response(5, true));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->type, SdoType::kDownloadSegment);
  EXPECT_TRUE(m->toggle);
  m = decode_sdo_response(*sdo_upload_initiate_response(5, 0x1008, 0, 1234));
  ASSERT_TRUE(m.ok());
  EXPECT_FALSE(m->expedited);
  EXPECT_EQ(m->size, 1234u);
  m = decode_sdo_request(*sdo_upload_segment_request(5, false));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->type, SdoType::kUploadSegment);
  EXPECT_FALSE(m->toggle);
  m = decode_sdo_request(*sdo_abort(5, SdoRole::kClient, 0x1A00, 2, SdoAbortCode::kTimeout));
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->type, SdoType::kAbort);
  EXPECT_EQ(m->abort_code, 0x05040000u);
}

// ---- segmented transfer helpers ---------------------------------------------------------

TEST(Sdo, SegmentedDownloadEndToEnd) {
  // 17 bytes = 7 + 7 + 3: toggles 0, 1, 0; the last has c = 1.
  std::vector<std::uint8_t> payload(17);
  std::iota(payload.begin(), payload.end(), std::uint8_t{0x40});
  SdoSegmentSender sender;
  sender.begin(payload);
  std::array<std::uint8_t, 32> buffer{};
  SdoSegmentReceiver receiver(buffer);
  receiver.begin(17);
  const std::uint8_t expected_first_bytes[] = {0x00, 0x10, 0x09};  // t0 c0; t1 c0; t0 n4 c1
  int i = 0;
  while (!sender.done()) {
    ASSERT_LT(i, 3);
    const SdoSegmentSender::Segment s = sender.next();
    const Result<CanFrame> f = sdo_download_segment(1, s.toggle, s.bytes, s.last);
    ASSERT_TRUE(f.ok());
    EXPECT_EQ(f->data[0], expected_first_bytes[i]) << i;
    const Result<SdoMessage> m = decode_sdo_request(*f);
    ASSERT_TRUE(m.ok());
    EXPECT_EQ(receiver.accept(*m), Error::kNone);
    // The server's confirmation echoes the toggle; the client checks it.
    const Result<SdoMessage> ack =
        decode_sdo_response(*sdo_download_segment_response(1, m->toggle));
    EXPECT_EQ(check_toggle(*ack, s.toggle), Error::kNone);
    ++i;
  }
  EXPECT_EQ(i, 3);
  EXPECT_TRUE(receiver.done());
  ASSERT_EQ(receiver.bytes().size(), 17u);
  EXPECT_TRUE(std::equal(payload.begin(), payload.end(), receiver.bytes().begin()));
}

TEST(Sdo, SegmentToggleMismatch) {
  std::array<std::uint8_t, 32> buffer{};
  SdoSegmentReceiver receiver(buffer);
  receiver.begin(0);
  // First segment must carry toggle 0; this one has 1 (10h).
  const Result<SdoMessage> bad = decode_sdo_request(make_frame(0x601, {0x10, 1, 2, 3, 4, 5, 6, 7}));
  ASSERT_TRUE(bad.ok());
  EXPECT_EQ(receiver.accept(*bad), Error::kToggleMismatch);
  EXPECT_TRUE(receiver.done());

  // A repeated toggle (0, 0) is a mismatch on the second segment.
  receiver.begin(0);
  const Result<SdoMessage> s0 = decode_sdo_request(make_frame(0x601, {0x00, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(receiver.accept(*s0), Error::kNone);
  EXPECT_EQ(receiver.accept(*s0), Error::kToggleMismatch);

  // Client side: a confirmation with the wrong toggle.
  const Result<SdoMessage> ack =
      decode_sdo_response(make_frame(0x581, {0x30, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(check_toggle(*ack, false), Error::kToggleMismatch);
  // Not a segment at all.
  const Result<SdoMessage> init =
      decode_sdo_response(make_frame(0x581, {0x60, 0x00, 0x10, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(check_toggle(*init, false), Error::kBadCommandSpecifier);
}

TEST(Sdo, SegmentSizeChecks) {
  std::array<std::uint8_t, 8> small{};
  SdoSegmentReceiver receiver(small);
  // Buffer overflow: 7 + 7 > 8.
  receiver.begin(0);
  EXPECT_EQ(receiver.accept(*decode_sdo_request(make_frame(0x601, {0x00, 1, 2, 3, 4, 5, 6, 7}))),
            Error::kNone);
  EXPECT_EQ(receiver.accept(*decode_sdo_request(make_frame(0x601, {0x10, 1, 2, 3, 4, 5, 6, 7}))),
            Error::kTooLong);
  // Announced 5, the only (last) segment brings 3 bytes (09h: t 0, n 4, c 1).
  receiver.begin(5);
  EXPECT_EQ(receiver.accept(*decode_sdo_request(make_frame(0x601, {0x09, 1, 2, 3, 0, 0, 0, 0}))),
            Error::kSizeMismatch);
  // Announced 2, a 3-byte segment exceeds it.
  receiver.begin(2);
  EXPECT_EQ(receiver.accept(*decode_sdo_request(make_frame(0x601, {0x09, 1, 2, 3, 0, 0, 0, 0}))),
            Error::kTooLong);
}

TEST(Sdo, SenderOfEmptyAndExactPayloads) {
  SdoSegmentSender s;
  s.begin({});
  SdoSegmentSender::Segment seg = s.next();
  EXPECT_TRUE(seg.last);
  EXPECT_EQ(seg.bytes.size(), 0u);
  EXPECT_TRUE(s.done());
  const std::array<std::uint8_t, 14> two{};
  s.begin(two);
  seg = s.next();
  EXPECT_FALSE(seg.last);
  EXPECT_FALSE(seg.toggle);
  EXPECT_EQ(seg.bytes.size(), 7u);
  EXPECT_TRUE(s.next_toggle());
  seg = s.next();
  EXPECT_TRUE(seg.last);
  EXPECT_TRUE(seg.toggle);
  EXPECT_EQ(seg.bytes.size(), 7u);
  EXPECT_TRUE(s.done());
}

TEST(Sdo, AbortTexts) {
  EXPECT_EQ(std::string(to_string(SdoAbortCode::kToggleNotAlternated)),
            "toggle bit not alternated");
  EXPECT_EQ(std::string(to_string(SdoAbortCode::kTimeout)), "SDO protocol timed out");
  EXPECT_EQ(std::string(sdo_abort_text(0x06010002)), "attempt to write a read only object");
  EXPECT_EQ(std::string(sdo_abort_text(0x08000022)),
            "data cannot be transferred or stored to the application because of the present "
            "device state");
  EXPECT_EQ(std::string(sdo_abort_text(0x12345678)), "unknown abort code");
}

TEST(Sdo, EveryEightByteFrameDecodesOrErrs) {
  // Seeded sweep over command bytes and payloads: decoders return a value or an error and
  // never read past the frame (ASan in CI).
  std::uint32_t x = 12345;
  for (int b0 = 0; b0 < 256; ++b0) {
    for (int k = 0; k < 8; ++k) {
      CanFrame f = make_frame(0x601, {static_cast<std::uint8_t>(b0), 0, 0, 0, 0, 0, 0, 0});
      for (std::size_t j = 1; j < 8; ++j) {
        x = x * 1664525u + 1013904223u;
        f.data[j] = static_cast<std::uint8_t>(x >> 24);
      }
      const Result<SdoMessage> req = decode_sdo_request(f);
      const int cs = b0 >> 5;
      EXPECT_EQ(req.ok(), cs <= 4) << b0;
      if (req.ok()) {
        EXPECT_LE(req->data_len, 7);
      }
      f.id = 0x581;
      const Result<SdoMessage> resp = decode_sdo_response(f);
      EXPECT_EQ(resp.ok(), cs <= 4) << b0;
      if (resp.ok()) {
        EXPECT_LE(resp->data_len, 7);
      }
    }
  }
}

}  // namespace
}  // namespace dualv::fw
