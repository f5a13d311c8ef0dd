// SdoClient against a scripted server: every response form CiA 301 7.2.4.3 allows a
// server, and the errors a client must detect. Each script is written by hand from the
// standard, frame by frame ("601#..." client -> server, as the client must send it;
// "581#..." server -> client, injected as a foreign stack would answer). Nothing here is
// produced by the code under test or by the project's own emulator.
//
// Command specifiers (CiA 301 7.2.4.3.3..7.2.4.3.17), server side:
//   upload initiate response   010 x n(2) e s  -> 4xh: 43h/47h/4Bh/4Fh (e=1, s=1, n = 4 - len)
//                                                    42h (e=1, s=0: length unspecified)
//                                                    41h (e=0, s=1: size in bytes 4..7)
//                                                    40h (e=0, s=0: size not indicated)
//   upload segment response    000 t n(3) c    -> t toggles from 0, n = 7 - len, c = last
//   download initiate response 011 00000       -> 60h
//   download segment response  001 t 0000      -> 20h / 30h
//   abort                      100 00000       -> 80h + multiplexer + code (LE)
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "drivers/canopen/sdo_client.hpp"
#include "fake_slave.hpp"

namespace dualv::drivers::canopen {
namespace {

using test::from_text;
using test::to_text;

constexpr std::uint64_t kTimeout = 100'000'000;

enum class Op { kUpload, kDownload };

struct SdoCase {
  const char* name;
  Op op;
  std::uint16_t index;
  std::uint8_t sub;
  std::size_t expected_size;          // upload: the object's size from its type (0 = unknown)
  std::vector<std::uint8_t> payload;  // download
  std::vector<std::string> script;    // ">601#..." the client sends, "<581#..." the server
  SdoStatus result;
  std::vector<std::uint8_t> uploaded;  // kDone uploads
  std::uint32_t abort_code;            // kAborted / kError
  bool mux_differed;
};

// Identity 1018h sub1 etc. are only names here: the server side is the script.
const std::vector<SdoCase>& cases() {
  static const std::vector<SdoCase> c = {
      // ---- expedited upload ------------------------------------------------------------
      {"ExpeditedU16WithSize",
       Op::kUpload,
       0x1017,
       0,
       2,
       {},
       {">601#4017100000000000", "<581#4B17100032000000"},
       SdoStatus::kDone,
       {0x32, 0x00},
       0,
       false},
      // The case: 1017h u16 answered e=1, s=0 (42h): four bytes, the length is the
      // object's (2), the rest is padding.
      {"ExpeditedU16WithoutSize",
       Op::kUpload,
       0x1017,
       0,
       2,
       {},
       {">601#4017100000000000", "<581#4217100032000000"},
       SdoStatus::kDone,
       {0x32, 0x00},
       0,
       false},
      {"ExpeditedI8WithoutSizePaddingIgnored",
       Op::kUpload,
       0x6061,
       0,
       1,
       {},
       {">601#4061600000000000", "<581#426160000AFFFFFF"},
       SdoStatus::kDone,
       {0x0A},
       0,
       false},
      {"ExpeditedU32WithoutSize",
       Op::kUpload,
       0x6076,
       0,
       4,
       {},
       {">601#4076600000000000", "<581#4276600050C30000"},
       SdoStatus::kDone,
       {0x50, 0xC3, 0x00, 0x00},
       0,
       false},
      {"ExpeditedU8WithSize",
       Op::kUpload,
       0x1001,
       0,
       1,
       {},
       {">601#4001100000000000", "<581#4F01100081000000"},
       SdoStatus::kDone,
       {0x81},
       0,
       false},
      {"ExpeditedThreeBytesWithSize",
       Op::kUpload,
       0x2000,
       1,
       0,
       {},
       {">601#4000200100000000", "<581#4700200101020300"},
       SdoStatus::kDone,
       {1, 2, 3},
       0,
       false},
      // ---- segmented upload ------------------------------------------------------------
      {"SegmentedWithSize",
       Op::kUpload,
       0x1008,
       0,
       0,
       {},
       {">601#4008100000000000", "<581#4108100005000000",   // 41h: size 5
        ">601#6000000000000000", "<581#0544554531000000"},  // t=0, n=2, c=1: "DUE1\0"
       SdoStatus::kDone,
       {0x44, 0x55, 0x45, 0x31, 0x00},
       0,
       false},
      {"SegmentedWithoutSize",
       Op::kUpload,
       0x1008,
       0,
       0,
       {},
       {">601#4008100000000000", "<581#4008100000000000",   // 40h: size not indicated
        ">601#6000000000000000", "<581#0001020304050607",   // t=0, 7 bytes, more follow
        ">601#7000000000000000", "<581#1B08090000000000"},  // t=1, n=5 (2 bytes), c=1
       SdoStatus::kDone,
       {1, 2, 3, 4, 5, 6, 7, 8, 9},
       0,
       false},
      {"SegmentedEmptyLastSegment",
       Op::kUpload,
       0x1008,
       0,
       0,
       {},
       {">601#4008100000000000", "<581#4108100007000000", ">601#6000000000000000",
        "<581#0001020304050607",                            // 7 bytes, not last
        ">601#7000000000000000", "<581#1F00000000000000"},  // t=1, n=7 (0 bytes), c=1
       SdoStatus::kDone,
       {1, 2, 3, 4, 5, 6, 7},
       0,
       false},
      {"SegmentedToggleNotAlternatedIsAborted",
       Op::kUpload,
       0x1008,
       0,
       0,
       {},
       {">601#4008100000000000", "<581#4108100009000000", ">601#6000000000000000",
        "<581#0001020304050607", ">601#7000000000000000", "<581#0B08090000000000",  // t=0 again
        ">601#8008100000000305"},  // client abort 05030000h
       SdoStatus::kError,
       {},
       0x05030000,
       false},
      {"SegmentedFirstToggleMustBeZero",
       Op::kUpload,
       0x1008,
       0,
       0,
       {},
       {">601#4008100000000000", "<581#4108100002000000", ">601#6000000000000000",
        "<581#1B01020000000000",  // t=1 on the first segment
        ">601#8008100000000305"},
       SdoStatus::kError,
       {},
       0x05030000,
       false},
      {"SegmentedShortOfAnnouncedSize",
       Op::kUpload,
       0x1008,
       0,
       0,
       {},
       {">601#4008100000000000", "<581#4108100005000000", ">601#6000000000000000",
        "<581#0B01020000000000",   // last with 2 of 5 bytes
        ">601#8008100010000706"},  // 06070010h length mismatch
       SdoStatus::kError,
       {},
       0x06070010,
       false},
      // ---- aborts ---------------------------------------------------------------------
      {"AbortSameMultiplexer",
       Op::kUpload,
       0x60C2,
       1,
       1,
       {},
       {">601#40C2600100000000", "<581#80C2600100000206"},  // 06020000h
       SdoStatus::kAborted,
       {},
       0x06020000,
       false},
      {"AbortWithOtherMultiplexerEndsTheTransfer",
       Op::kUpload,
       0x1008,
       0,
       0,
       {},
       {">601#4008100000000000", "<581#4108100009000000", ">601#6000000000000000",
        "<581#8000000000000008"},  // mux 0000h/00, 08000000h
       SdoStatus::kAborted,
       {},
       0x08000000,
       true},
      {"AbortOfADownload",
       Op::kDownload,
       0x6072,
       0,
       0,
       {0x20, 0x4E},
       {">601#2B726000204E0000", "<581#8072600031000906"},  // 06090031h value too high
       SdoStatus::kAborted,
       {},
       0x06090031,
       false},
      // ---- wrong answers the client must refuse -----------------------------------------
      {"InitiateResponseForAnotherObject",
       Op::kUpload,
       0x1017,
       0,
       2,
       {},
       {">601#4017100000000000", "<581#4B18100032000000",  // 1018h: not our request
        ">601#8017100000000008"},                          // 08000000h general error
       SdoStatus::kError,
       {},
       0x08000000,
       false},
      {"UnknownServerCommandSpecifier",
       Op::kUpload,
       0x1017,
       0,
       2,
       {},
       {">601#4017100000000000", "<581#E017100000000000",  // scs 7
        ">601#8017100001000405"},                          // 05040001h
       SdoStatus::kError,
       {},
       0x05040001,
       false},
      {"DownloadAnswerToAnUpload",
       Op::kUpload,
       0x1017,
       0,
       2,
       {},
       {">601#4017100000000000", "<581#6017100000000000", ">601#8017100001000405"},
       SdoStatus::kError,
       {},
       0x05040001,
       false},
      {"ExpeditedLongerThanTheBuffer",
       Op::kUpload,
       0x1017,
       0,
       0,
       {},
       {">601#4017100000000000", "<581#4317100001020304",  // 4 bytes into a 2-byte buffer
        ">601#8017100012000706"},                          // 06070012h
       SdoStatus::kError,
       {},
       0x06070012,
       false},
      // ---- download -------------------------------------------------------------------
      {"ExpeditedDownloadConfirmed",
       Op::kDownload,
       0x6060,
       0,
       0,
       {0x0A},
       {">601#2F6060000A000000", "<581#6060600000000000"},
       SdoStatus::kDone,
       {},
       0,
       false},
      {"SegmentedDownload",
       Op::kDownload,
       0x2000,
       0,
       0,
       {1, 2, 3, 4, 5, 6, 7, 8, 9},
       {">601#2100200009000000", "<581#6000200000000000", ">601#0001020304050607",
        "<581#2000000000000000",                            // t=0 echoed
        ">601#1B08090000000000", "<581#3000000000000000"},  // t=1, n=5, c=1; t=1 echoed
       SdoStatus::kDone,
       {},
       0,
       false},
      {"SegmentedDownloadToggleNotEchoed",
       Op::kDownload,
       0x2000,
       0,
       0,
       {1, 2, 3, 4, 5, 6, 7, 8, 9},
       {">601#2100200009000000", "<581#6000200000000000", ">601#0001020304050607",
        "<581#3000000000000000",  // t=1 answers t=0
        ">601#8000200000000305"},
       SdoStatus::kError,
       {},
       0x05030000,
       false},
  };
  return c;
}

class SdoConformance : public ::testing::TestWithParam<SdoCase> {};

TEST_P(SdoConformance, ClientFollowsTheScript) {
  const SdoCase& c = GetParam();
  InProcessHub hub{2};
  InProcessBus& client_end = hub.endpoint(0);
  InProcessBus& server_end = hub.endpoint(1);
  SdoClient client{1, kTimeout};
  std::array<std::uint8_t, 16> buffer{};
  const std::size_t buffer_size = c.expected_size != 0 ? c.expected_size
                                  : c.index == 0x1017  ? 2
                                                       : buffer.size();
  ASSERT_EQ(c.op == Op::kUpload
                ? client.upload(client_end, c.index, c.sub, std::span(buffer).first(buffer_size), 0,
                                c.expected_size)
                : client.download(client_end, c.index, c.sub, c.payload, 0),
            SdoStatus::kBusy);
  std::uint64_t now = 0;
  for (const std::string& step : c.script) {
    now += 1000;
    if (step[0] == '>') {
      fw::CanFrame got;
      ASSERT_EQ(server_end.receive(got), BusStatus::kOk) << "expected " << step.substr(1);
      EXPECT_EQ(to_text(got), step.substr(1));
    } else {
      ASSERT_EQ(server_end.send(from_text(step.substr(1))), BusStatus::kOk);
      fw::CanFrame f;
      while (client_end.receive(f) == BusStatus::kOk) client.on_frame(client_end, f, now);
    }
  }
  fw::CanFrame extra;
  EXPECT_NE(server_end.receive(extra), BusStatus::kOk) << "unexpected " << to_text(extra);
  EXPECT_EQ(client.status(), c.result) << to_string(client.status());
  if (c.result == SdoStatus::kDone && c.op == Op::kUpload) {
    const auto got = client.uploaded();
    EXPECT_EQ(std::vector<std::uint8_t>(got.begin(), got.end()), c.uploaded);
  }
  EXPECT_EQ(client.abort_code(), c.abort_code);
  EXPECT_EQ(client.abort_multiplexer_differed(), c.mux_differed);
}

INSTANTIATE_TEST_SUITE_P(Cia301, SdoConformance, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<SdoCase>& i) { return i.param.name; });

}  // namespace
}  // namespace dualv::drivers::canopen
