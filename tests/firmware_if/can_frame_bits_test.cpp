// The frame-size model (firmware_if/can_frame_bits.hpp) against frames built here bit by bit
// from the frame format of ISO 11898-1:2015 (fields, CRC-15, dynamic stuffing, CAN FD stuff
// count and fixed stuff bits), independently of the model's formulas.
#include "firmware_if/can_frame_bits.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace dualv::fw {
namespace {

// One bit on the wire and the phase it travels in (true = FD data phase).
struct WireBit {
  int value = 1;
  bool data_phase = false;
};
using Bits = std::vector<int>;
inline constexpr std::size_t kNoDataPhase = ~std::size_t{0};  // classic frames

void push(Bits& b, std::uint32_t v, int width) {
  for (int i = width - 1; i >= 0; --i) b.push_back(static_cast<int>((v >> i) & 1u));
}

// CRC-15 of classic CAN: generator x^15+x^14+x^10+x^8+x^7+x^4+x^3+1 (4599h), register 0.
std::uint16_t crc15(const Bits& bits) {
  std::uint16_t crc = 0;
  for (int b : bits) {
    const int next = b ^ ((crc >> 14) & 1);
    crc = static_cast<std::uint16_t>((crc << 1) & 0x7FFF);
    if (next) crc ^= 0x4599;
  }
  return crc;
}

// Dynamic stuffing: after 5 equal bits (stuff bits count) the complement is inserted.
// `first_data_bit`: index of the first data-phase bit (FD: ESI); a stuff bit after the bit just
// before it (BRS) already goes out after the switch.
std::vector<WireBit> stuff(const Bits& in, std::size_t first_data_bit, int& stuff_bits) {
  std::vector<WireBit> out;
  int run = 0, last = -1;
  stuff_bits = 0;
  for (std::size_t i = 0; i < in.size(); ++i) {
    out.push_back({in[i], i >= first_data_bit});
    run = in[i] == last ? run + 1 : 1;
    last = in[i];
    if (run == 5) {
      out.push_back({1 - last, i + 1 >= first_data_bit});
      last = 1 - last;
      run = 1;
      ++stuff_bits;
    }
  }
  return out;
}
int stuff_count(const Bits& in) {
  int n = 0;
  (void)stuff(in, kNoDataPhase, n);
  return n;
}

struct BuiltFrame {
  std::uint32_t nominal = 0, data = 0;
  int dynamic_stuff = 0;
  std::uint32_t crc_field = 0;  // FD: stuff count + fixed stuff bits + CRC sequence
  std::string wire;             // the bits, for hand checks
};
void count(BuiltFrame& f, const std::vector<WireBit>& bits) {
  for (const WireBit& b : bits) {
    (b.data_phase ? f.data : f.nominal) += 1;
    f.wire.push_back(b.value ? '1' : '0');
  }
}
void tail(BuiltFrame& f) {  // CRC delimiter, ACK slot (recessive as sent), ACK delim, EOF, IFS
  count(f, std::vector<WireBit>(13, WireBit{1, false}));
}

// Classic base frame: SOF, id, RTR, IDE, r0, DLC, data, CRC-15 (all stuffed), tail.
BuiltFrame classic_frame(std::uint16_t id, const std::vector<std::uint8_t>& data) {
  Bits b{0};
  push(b, id, 11);
  b.insert(b.end(), {0, 0, 0});
  push(b, static_cast<std::uint32_t>(data.size()), 4);
  for (std::uint8_t byte : data) push(b, byte, 8);
  push(b, crc15(b), 15);
  BuiltFrame f;
  count(f, stuff(b, kNoDataPhase, f.dynamic_stuff));
  tail(f);
  return f;
}

// CAN FD base frame with bit-rate switch. The CRC sequence is `crc_fill` repeated: the CRC
// field is not dynamically stuffed, so its value cannot change the frame's length (checked
// below with both fills).
BuiltFrame fd_frame(std::uint16_t id, const std::vector<std::uint8_t>& data, int crc_fill) {
  std::uint8_t dlc = 0;
  while (kFdDlcBytes[dlc] != data.size()) ++dlc;
  Bits b{0};
  push(b, id, 11);
  b.insert(b.end(), {0, 0, 1, 0, 1});  // RRS, IDE, FDF, res, BRS
  const std::size_t first_data = b.size();
  b.push_back(0);  // ESI (error active)
  push(b, dlc, 4);
  for (std::uint8_t byte : data) push(b, byte, 8);
  BuiltFrame f;
  std::vector<WireBit> wire = stuff(b, first_data, f.dynamic_stuff);
  // Stuff count: Gray code of (count mod 8), then even parity over those 3 bits.
  const unsigned mod = static_cast<unsigned>(f.dynamic_stuff) % 8;
  const unsigned gray = mod ^ (mod >> 1);
  Bits coded;
  push(coded, gray, 3);
  coded.push_back(static_cast<int>(((gray >> 2) ^ (gray >> 1) ^ gray) & 1u));
  const int crc_bits = data.size() <= 16 ? 17 : 21;
  for (int i = 0; i < crc_bits; ++i) coded.push_back(crc_fill);
  // Fixed stuff bits: before the stuff count and after every 4th coded bit, each the
  // complement of the bit before it.
  const std::uint32_t before = static_cast<std::uint32_t>(wire.size());
  wire.push_back({1 - wire.back().value, true});
  for (std::size_t i = 0; i < coded.size(); ++i) {
    wire.push_back({coded[i], true});
    if ((i + 1) % 4 == 0 && i + 1 < coded.size()) wire.push_back({1 - coded[i], true});
  }
  f.crc_field = static_cast<std::uint32_t>(wire.size()) - before;
  count(f, wire);
  tail(f);
  return f;
}

std::vector<std::uint8_t> random_bytes(std::mt19937& rng, std::size_t n) {
  std::vector<std::uint8_t> v(n);
  for (auto& x : v) x = static_cast<std::uint8_t>(rng() & 0xFF);
  return v;
}

TEST(CanFrameBits, Crc15CheckValue) {
  // The CRC catalogue's check value of CRC-15/CAN: "123456789" -> 059Eh.
  Bits b;
  for (char c : std::string("123456789")) push(b, static_cast<std::uint8_t>(c), 8);
  EXPECT_EQ(crc15(b), 0x059E);
}

TEST(CanFrameBits, SyncFrameByHand) {
  // SYNC, id 080h, no data. Fields: SOF 0 | id 00010000000 | RTR 0 IDE 0 r0 0 | DLC 0000 |
  // CRC-15 001110000000101 (1C05h), then stuff bits (marked ^) after every 5 equal bits:
  // 00001^000001^000001^000001^0111000001^00101 -> 34 + 4 bits, then the 13-bit tail: 51.
  const BuiltFrame f = classic_frame(0x080, {});
  EXPECT_EQ(f.wire.substr(0, 38), "00001000001000001000001011100000100101");
  EXPECT_EQ(f.dynamic_stuff, 4);
  EXPECT_EQ(f.nominal, 51u);
  EXPECT_LE(f.nominal, classic_frame_bits(0).total());  // the worst case, 55
}

TEST(CanFrameBits, ClassicWithoutStuffingMatchesFrameFormat) {
  std::mt19937 rng(1);
  for (std::uint8_t n = 0; n <= kClassicMaxBytes; ++n) {
    const BuiltFrame f = classic_frame(0x123, random_bytes(rng, n));
    EXPECT_EQ(f.nominal - static_cast<std::uint32_t>(f.dynamic_stuff),
              classic_frame_bits(n, Stuffing::kNone).total())
        << int(n) << " bytes";
    EXPECT_EQ(classic_frame_bits(n, Stuffing::kNone).data, 0u);
  }
  // 47 + 8n by hand, and the extended format's 67 + 8n.
  EXPECT_EQ(classic_frame_bits(8, Stuffing::kNone).total(), 111u);
  EXPECT_EQ(classic_extended_frame_bits(0, Stuffing::kNone).total(), 67u);
}

TEST(CanFrameBits, ClassicWorstCaseBoundsEveryFrame) {
  // Hand values of 47 + 8n + floor((34 + 8n - 1) / 4) (docs/architecture.md): 55, 75, 95, 115, 135.
  EXPECT_EQ(classic_frame_bits(0).total(), 55u);
  EXPECT_EQ(classic_frame_bits(2).total(), 75u);
  EXPECT_EQ(classic_frame_bits(4).total(), 95u);
  EXPECT_EQ(classic_frame_bits(6).total(), 115u);
  EXPECT_EQ(classic_frame_bits(8).total(), 135u);
  EXPECT_EQ(classic_frame_bits(9).total(), 135u);
  std::mt19937 rng(2);
  for (std::uint8_t n = 0; n <= kClassicMaxBytes; ++n) {
    std::uint32_t longest = 0;
    for (int k = 0; k < 400; ++k) {
      const auto id = static_cast<std::uint16_t>(rng() & 0x7FF);
      longest = std::max(longest, classic_frame(id, random_bytes(rng, n)).nominal);
    }
    // Runs of equal bits stuff the most: id 0 and all-zero or all-one data.
    longest = std::max(longest, classic_frame(0x000, std::vector<std::uint8_t>(n, 0x00)).nominal);
    longest = std::max(longest, classic_frame(0x7FF, std::vector<std::uint8_t>(n, 0xFF)).nominal);
    EXPECT_LE(longest, classic_frame_bits(n).total()) << int(n) << " bytes";
    EXPECT_GT(longest, classic_frame_bits(n, Stuffing::kNone).total()) << int(n) << " bytes";
  }
}

TEST(CanFrameBits, WorstCaseStuffingIsReachedAndNeverExceeded) {
  // Every bit string of up to 16 bits: the most stuff bits is floor((L - 1) / 4).
  for (int len = 1; len <= 16; ++len) {
    int most = 0;
    for (std::uint32_t v = 0; v < (1u << len); ++v) {
      Bits b;
      push(b, v, len);
      most = std::max(most, stuff_count(b));
    }
    EXPECT_EQ(static_cast<std::uint32_t>(most),
              worst_case_stuff_bits(static_cast<std::uint32_t>(len)))
        << len << " bits";
  }
  // Longer: 00000 1111 0000 1111 ... (each stuff bit starts the next run) reaches the bound
  // for every classic and FD stuffed length.
  for (std::uint32_t len : {34u, 66u, 98u, 22u + 8u * 16u, 22u + 8u * 64u}) {
    Bits b(5, 0);
    int v = 1;
    while (b.size() < len) {
      for (int i = 0; i < 4 && b.size() < len; ++i) b.push_back(v);
      v = 1 - v;
    }
    EXPECT_EQ(static_cast<std::uint32_t>(stuff_count(b)), worst_case_stuff_bits(len)) << len;
  }
}

TEST(CanFrameBits, FdFrameByHand) {
  // FD base frame, id 078h, no data, CRC sequence all 0. Dynamic part (stuff bits marked ^):
  // SOF 0 | id 0000^1 1111^0 000 | RRS 0^1 | IDE 0 FDF 1 res 0 BRS 1 | ESI 0 DLC 0000^1:
  // 3 stuff bits before the bit-rate switch, 1 after. CRC field: fixed stuff bit 0 (the
  // complement of the 1 before), stuff count 4 -> Gray 110 + even parity 0, fixed 1, then the
  // 17 CRC bits with a fixed stuff bit after every 4th coded bit: 27 bits.
  const BuiltFrame f = fd_frame(0x078, {}, 0);
  EXPECT_EQ(f.wire.substr(0, 26), "00000111110000010101000001");
  EXPECT_EQ(f.wire.substr(26, 27), "011001000010000100001000010");
  EXPECT_EQ(f.dynamic_stuff, 4);
  // Nominal: 17 + 3 stuff + 13 tail = 33; data: ESI + DLC 5 + 1 stuff + 27 = 33.
  EXPECT_EQ(f.nominal, 33u);
  EXPECT_EQ(f.data, 33u);
  EXPECT_EQ(f.crc_field, 27u);
  EXPECT_LE(f.nominal, fd_frame_bits(0).nominal);
  EXPECT_LE(f.nominal + f.data, fd_frame_bits(0).total());
}

TEST(CanFrameBits, FdSizes) {
  EXPECT_EQ(fd_frame_bytes(6), 6);
  EXPECT_EQ(fd_frame_bytes(9), 12);
  EXPECT_EQ(fd_frame_bytes(16), 16);
  EXPECT_EQ(fd_frame_bytes(33), 48);
  EXPECT_EQ(fd_frame_bytes(200), 64);
  EXPECT_EQ(fd_dlc_code(12), 9);
  EXPECT_EQ(fd_dlc_code(64), 15);
  EXPECT_EQ(fd_crc_bits(16), 17u);
  EXPECT_EQ(fd_crc_bits(20), 21u);
  // Stuff count 4 + CRC-17 + 6 fixed stuff bits; 4 + CRC-21 + 7.
  EXPECT_EQ(fd_crc_field_bits(16), 27u);
  EXPECT_EQ(fd_crc_field_bits(64), 32u);
}

TEST(CanFrameBits, FdWithoutStuffingMatchesFrameFormat) {
  std::mt19937 rng(3);
  for (std::uint8_t n : kFdDlcBytes) {
    for (int fill : {0, 1}) {
      const BuiltFrame f = fd_frame(0x201, random_bytes(rng, n), fill);
      EXPECT_EQ(f.crc_field, fd_crc_field_bits(n)) << int(n) << " bytes";
      const FrameBits model = fd_frame_bits(n, Stuffing::kNone);
      // The built frame's stuff bits are the dynamic ones only (the fixed ones are in the
      // model's CRC field); take them out of whichever phase they fell in.
      EXPECT_EQ(f.nominal + f.data - static_cast<std::uint32_t>(f.dynamic_stuff), model.total())
          << int(n) << " bytes";
      EXPECT_GE(f.nominal, model.nominal);
      EXPECT_LE(f.nominal - model.nominal, kFdArbitrationStuffBits);
    }
  }
  // By hand: 16 bytes = 17 + 13 nominal, 5 + 128 + 27 data; without the bit-rate switch all
  // of it at the nominal rate.
  EXPECT_EQ(fd_frame_bits(16, Stuffing::kNone), (FrameBits{30, 160}));
  EXPECT_EQ(fd_frame_bits(16, Stuffing::kNone, false), (FrameBits{190, 0}));
}

TEST(CanFrameBits, FdArbitrationStuffBitsOverEveryIdentifier) {
  // The most stuff bits before the bit-rate switch, over all 2048 identifiers, bit by bit.
  int most = 0;
  for (std::uint16_t id = 0; id < 2048; ++id) {
    const BuiltFrame f = fd_frame(id, {}, 0);
    most = std::max(most, static_cast<int>(f.nominal) - 30);
  }
  EXPECT_EQ(most, static_cast<int>(kFdArbitrationStuffBits));
}

TEST(CanFrameBits, FdWorstCaseBoundsEveryFrame) {
  // By hand (worst case): nominal 17 + 13 + 3 = 33; data 5 + 8n + CRC field + stuff - 3:
  // 6 B: 5 + 48 + 27 + (floor(69 / 4) - 3 = 14) = 94; 16 B: 5 + 128 + 27 + 34 = 194;
  // 64 B: 5 + 512 + 32 + (floor(533 / 4) - 3 = 130) = 679.
  EXPECT_EQ(fd_frame_bits(6), (FrameBits{33, 94}));
  EXPECT_EQ(fd_frame_bits(16), (FrameBits{33, 194}));
  EXPECT_EQ(fd_frame_bits(64), (FrameBits{33, 679}));
  EXPECT_EQ(fd_frame_bits(13), fd_frame_bits(16));  // rounded up to the DLC size
  // 1 Mbit/s nominal, 5 Mbit/s data: 16 B take 33 us + 38.8 us.
  EXPECT_NEAR(fd_frame_bits(16).seconds(1'000'000, 5'000'000), 71.8e-6, 1e-12);
  std::mt19937 rng(4);
  for (std::uint8_t n : kFdDlcBytes) {
    const FrameBits bound = fd_frame_bits(n);
    double longest = 0.0;
    std::uint32_t most_bits = 0;
    auto check = [&](const BuiltFrame& f) {
      longest = std::max(longest, FrameBits{f.nominal, f.data}.seconds(1'000'000, 5'000'000));
      most_bits = std::max(most_bits, f.nominal + f.data);
      EXPECT_LE(f.nominal, bound.nominal);
    };
    for (int k = 0; k < 200; ++k)
      check(fd_frame(static_cast<std::uint16_t>(rng() & 0x7FF), random_bytes(rng, n), k & 1));
    check(fd_frame(0x000, std::vector<std::uint8_t>(n, 0x00), 0));
    check(fd_frame(0x7FF, std::vector<std::uint8_t>(n, 0xFF), 1));
    EXPECT_LE(longest, bound.seconds(1'000'000, 5'000'000) + 1e-15) << int(n) << " bytes";
    EXPECT_LE(most_bits, bound.total()) << int(n) << " bytes";
  }
}

}  // namespace
}  // namespace dualv::fw
