// The SDO server part of the emulated slave (sim/canopen/sdo_server.hpp) with frames alone:
// each request and its expected response written by hand from CiA 301 7.2.4.3, against a
// small dictionary and a recording download hook.
#include "sim/canopen/sdo_server.hpp"

#include <gtest/gtest.h>

#include "tests/sim/canopen/frame_text.hpp"

#include <algorithm>
#include <iterator>
#include <string>
#include <vector>

#include "firmware_if/byte_order.hpp"

namespace dualv::sim::canopen {
namespace {

fw::CanFrame parse(const std::string& text) {
  fw::CanFrame f;
  const std::size_t hash = text.find('#');
  f.id = static_cast<std::uint32_t>(std::stoul(text.substr(0, hash), nullptr, 16));
  const std::string data = text.substr(hash + 1);
  f.dlc = static_cast<std::uint8_t>(data.size() / 2);
  for (std::size_t i = 0; i < f.dlc; ++i)
    f.data[i] = static_cast<std::uint8_t>(std::stoul(data.substr(2 * i, 2), nullptr, 16));
  return f;
}
using test::text;

struct Recorder final : SdoServerHooks {
  ObjectDictionary* od = nullptr;
  std::vector<std::pair<int, std::uint32_t>> downloads;
  std::uint32_t refuse_with = 0;
  int uploads = 0;
  std::uint32_t download(int slot, std::uint32_t value) noexcept override {
    if (refuse_with != 0) return refuse_with;
    downloads.emplace_back(slot, value);
    od->set(slot, value);
    return 0;
  }
  void before_upload(int) noexcept override { ++uploads; }
};

constexpr fw::OdEntry kWriteOnly{0x2001, 0, fw::DataType::kUnsigned8, fw::Access::kWo, false, "wo"};

struct Server : ::testing::Test {
  ObjectDictionary od;
  Recorder hooks;
  SdoServer server;
  int s_cw = -1, s_count = -1;
  void SetUp() override {
    od.add(fw::od::kDeviceType, 0x00020192);
    s_count = od.add(fw::od::kIdentityCount, 4);
    od.add(fw::od::kIdentityVendorId, 0);
    s_cw = od.add(fw::od::kControlword, 0);
    od.add(fw::od::kRatedTorque, 50000);
    od.add(kWriteOnly, 0);
    hooks.od = &od;
    server.configure(5, {});
  }
  // The response to `request`, "" when none.
  std::string ask(const std::string& request) {
    fw::CanFrame r;
    return server.on_request(parse(request), od, hooks, r) ? text(r) : std::string();
  }
};

TEST_F(Server, ExpeditedUploadsAndAborts) {
  EXPECT_EQ(ask("605#4000100000000000"), "585#4300100092010200");  // 43h: 4 bytes
  EXPECT_EQ(ask("605#4018100000000000"), "585#4F18100004000000");  // 1018h sub0 = 4
  EXPECT_EQ(ask("605#4040600000000000"), "585#4B40600000000000");  // 4Bh: 2 bytes
  EXPECT_EQ(ask("605#4000200000000000"), "585#8000200000000206");  // 06020000h
  EXPECT_EQ(ask("605#4018100500000000"), "585#8018100511000906");  // 06090011h
  EXPECT_EQ(ask("605#4001200000000000"), "585#8001200001000106");  // 06010001h write-only
  EXPECT_EQ(hooks.uploads, 3);
  EXPECT_EQ(server.aborts_sent(), 3u);
}

TEST_F(Server, ExpeditedDownloads) {
  EXPECT_EQ(ask("605#2B40600006000000"), "585#6040600000000000");
  ASSERT_EQ(hooks.downloads.size(), 1u);
  EXPECT_EQ(hooks.downloads[0], std::make_pair(s_cw, 6u));
  EXPECT_EQ(ask("605#2340600006000000"), "585#8040600012000706");  // 4 bytes to u16: 06070012h
  EXPECT_EQ(ask("605#2F40600006000000"), "585#8040600013000706");  // 1 byte to u16: 06070013h
  EXPECT_EQ(ask("605#2300100001000000"), "585#8000100002000106");  // read-only: 06010002h
  EXPECT_EQ(ask("605#2F18100001000000"), "585#8018100002000106");  // const sub0: 06010002h
  hooks.refuse_with = 0x06090030;
  EXPECT_EQ(ask("605#2B40600006000000"), "585#8040600030000906");  // the hook's code
  // e=1, s=0 download: the object's size is taken from the dictionary.
  hooks.refuse_with = 0;
  EXPECT_EQ(ask("605#2240600007000000"), "585#6040600000000000");
  EXPECT_EQ(od.u(s_cw), 7u);
}

TEST_F(Server, SegmentedDownloadAndToggle) {
  EXPECT_EQ(ask("605#2176600004000000"), "585#6076600000000000");  // 21h: size 4
  EXPECT_TRUE(server.busy());
  EXPECT_EQ(ask("605#0720A10700000000"), "585#2000000000000000");  // t=0, n=3, c=1
  EXPECT_FALSE(server.busy());
  EXPECT_EQ(od.u(od.find(fw::od::kRatedTorque)), 0x0007A120u);  // 500000
  // A segment while no transfer is open: 05040001h, multiplexer 0.
  EXPECT_EQ(ask("605#0000000000000000"), "585#8000000001000405");
  // Toggle not alternated: the first segment must carry t=0.
  EXPECT_EQ(ask("605#2176600004000000"), "585#6076600000000000");
  EXPECT_EQ(ask("605#1720A10700000000"), "585#8076600000000305");
  // Size announced 2 for a 4-byte object: 06070013h.
  EXPECT_EQ(ask("605#2176600002000000"), "585#8076600013000706");
}

TEST_F(Server, SegmentedUploadOption) {
  server.configure(5, {.segmented_upload = true});
  EXPECT_EQ(ask("605#4076600000000000"), "585#4176600004000000");  // 41h, size 4
  EXPECT_EQ(ask("605#6000000000000000"), "585#0750C30000000000");  // t=0, n=3, c=1
  EXPECT_FALSE(server.busy());
  EXPECT_EQ(ask("605#4076600000000000"), "585#4176600004000000");
  EXPECT_EQ(ask("605#7000000000000000"), "585#8076600000000305");  // t=1 first: 05030000h
}

TEST_F(Server, UploadWithoutSizeOption) {
  server.configure(5, {.upload_without_size = true});
  EXPECT_EQ(ask("605#4040600000000000"), "585#4240600000000000");
  EXPECT_EQ(ask("605#4076600000000000"), "585#4276600050C30000");
}

TEST_F(Server, NotARequestOrClientAbort) {
  EXPECT_EQ(ask("606#4000100000000000"), "");                      // another node's channel
  EXPECT_EQ(ask("605#40001000"), "");                              // DLC 4: not an SDO frame
  EXPECT_EQ(ask("605#E000100000000000"), "585#8000100001000405");  // ccs 7: 05040001h
  EXPECT_EQ(ask("605#2176600004000000"), "585#6076600000000000");
  EXPECT_EQ(ask("605#8076600000000008"), "");  // the client aborts: no answer
  EXPECT_FALSE(server.busy());
}

TEST(ObjectDictionaryPart, AbsentObjectsAndReset) {
  ObjectDictionary od;
  od.set_absent({0x60C2});
  EXPECT_EQ(od.add(fw::od::kInterpolationPeriodValue, 1), -1);
  const int s = od.add(fw::od::kAbortConnectionOption, 3);
  ASSERT_GE(s, 0);
  EXPECT_FALSE(od.has_index(0x60C2));
  od.set(s, 0xFFFF);
  EXPECT_EQ(od.i(s), -1);  // INTEGER16
  od.reset(0x6000, 0x67FF);
  EXPECT_EQ(od.u(s), 3u);
  EXPECT_EQ(od.u(-1), 0u);
  EXPECT_THROW(od.add(fw::od::kAbortConnectionOption, 0), std::logic_error);
}

// find() and has_index() search a sorted key table (sim/canopen/object_dictionary.hpp): every
// entry of firmware_if, added in reverse order, is found at its own slot, and only those.
TEST(ObjectDictionaryPart, FindsEveryEntryWhateverTheOrderAdded) {
  ObjectDictionary od;
  std::vector<int> slots;
  for (auto it = std::rbegin(fw::od::kAll); it != std::rend(fw::od::kAll); ++it)
    slots.push_back(od.add(*it, 0));
  ASSERT_EQ(od.size(), std::size(fw::od::kAll));
  std::size_t k = slots.size();
  for (const fw::OdEntry& e : fw::od::kAll) {
    const int slot = slots[--k];
    EXPECT_EQ(slot, static_cast<int>(k));  // added in reverse: slots count down
    EXPECT_EQ(od.find(e), slot) << std::hex << e.index << "sub" << int{e.subindex};
    EXPECT_EQ(od.entry(slot).index, e.index);
    EXPECT_EQ(od.entry(slot).subindex, e.subindex);
    EXPECT_TRUE(od.has_index(e.index));
  }
  for (const fw::OdEntry& e : fw::od::kAll) {
    const bool sub_listed =
        std::any_of(std::begin(fw::od::kAll), std::end(fw::od::kAll), [&](const fw::OdEntry& o) {
          return o.index == e.index && o.subindex == static_cast<std::uint8_t>(e.subindex + 1);
        });
    if (!sub_listed) {
      EXPECT_EQ(od.find(e.index, static_cast<std::uint8_t>(e.subindex + 1)), -1);
    }
  }
  EXPECT_EQ(od.find(0x0000, 0), -1);
  EXPECT_EQ(od.find(0xFFFF, 0xFF), -1);
  EXPECT_FALSE(od.has_index(0x0000));
  EXPECT_FALSE(od.has_index(0xFFFF));
  EXPECT_THROW(od.add(fw::od::kAll[0], 0), std::logic_error);
}

}  // namespace
}  // namespace dualv::sim::canopen
