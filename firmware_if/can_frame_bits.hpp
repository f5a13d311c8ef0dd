#pragma once
// Bits on the wire of one CAN data frame, classic CAN and CAN FD, without stuffing and in the
// worst case of bit stuffing (docs/architecture.md "Beating the naive bus limit"). The frame fields
// are those of ISO 11898-1:2015 (clause 10.4, frame formats; clause 10.5, frame coding); the FD
// frame is that of the Bosch "CAN with Flexible Data-Rate" specification 1.0 (2012) with the
// ISO additions (stuff count, CRC over the dynamic stuff bits).
//
// Classic base frame (11-bit id), n = 0..8 data bytes:
//   stuffed:   SOF 1, id 11, RTR 1, IDE 1, r0 1, DLC 4, data 8n, CRC 15   = 34 + 8n bits
//   unstuffed: CRC delimiter 1, ACK slot 1, ACK delimiter 1, EOF 7, IFS 3 = 13 bits
// A stuff bit follows every 5 equal bits and starts a new run itself, so in the worst case the
// first comes after 5 bits and then one after every 4: floor((L - 1) / 4) stuff bits over L
// stuffed bits (Davis, Burns, Bril, Lukkien, "Controller Area Network (CAN) schedulability
// analysis: refuted, revisited and revised", Real-Time Systems 35, 2007, eq. 1):
//   classic bits = 47 + 8n + floor((34 + 8n - 1) / 4)     (55 for n = 0, 135 for n = 8)
// Extended (29-bit) frames add SRR, 18 id bits and r1: 54 + 8n stuffed bits.
//
// CAN FD base frame (FBFF) with bit-rate switch, n in {0..8, 12, 16, 20, 24, 32, 48, 64}:
//   arbitration phase, nominal rate: SOF 1, id 11, RRS 1, IDE 1, FDF 1, res 1, BRS 1 = 17
//   data phase, data rate:           ESI 1, DLC 4, data 8n, CRC field
//   frame tail, nominal rate:        CRC delimiter 1, ACK 1, ACK delimiter 1, EOF 7, IFS 3 = 13
// The rate switches at the sample points of BRS and of the CRC delimiter; both bits are counted
// whole at the (slower) nominal rate, which keeps the figure an upper bound.
// Dynamic stuffing covers SOF..data (22 + 8n bits): at most floor((22 + 8n - 1) / 4) stuff
// bits. Of those at most 3 fall before the switch: 14 bits SOF..IDE hold floor(13 / 4) = 3,
// and FDF = 1, res = 0, BRS = 1 alternate after IDE = 0 so no run of 5 can end there (the test
// recomputes this bit by bit for all 2048 identifiers). A stuff bit costs more at the nominal
// rate, so the worst case puts 3 there and the rest in the data phase.
// CRC field (ISO 11898-1:2015): stuff count (3-bit Gray-coded count of the dynamic stuff bits
// mod 8 + parity = 4 bits), then the CRC sequence, CRC-17 for n <= 16 bytes and CRC-21 above.
// It is not dynamically stuffed; fixed stuff bits (the complement of the bit before) go before
// the stuff count and after every 4th bit of stuff count + CRC: 1 + floor((4 + c - 1) / 4)
// bits, so the field is 4 + 17 + 6 = 27 bits (CRC-17) or 4 + 21 + 7 = 32 bits (CRC-21),
// whatever its value.
#include <array>
#include <cstdint>

#include "firmware_if/can_frame.hpp"

namespace dualv::fw {

enum class Stuffing : std::uint8_t {
  kNone,       // no stuff bits (the shortest a frame can be)
  kWorstCase,  // the most stuff bits any identifier and payload can cause
};

// The bits of one frame, split by the rate they travel at.
struct FrameBits {
  std::uint32_t nominal = 0;  // arbitration phase and frame tail (all of a classic frame)
  std::uint32_t data = 0;     // CAN FD data phase with bit-rate switch
  constexpr std::uint32_t total() const noexcept { return nominal + data; }
  // Time on the bus [s]; 0 when a needed bit rate is 0.
  constexpr double seconds(std::uint32_t nominal_bitrate,
                           std::uint32_t data_bitrate) const noexcept {
    if (nominal_bitrate == 0 || (data > 0 && data_bitrate == 0)) return 0.0;
    return static_cast<double>(nominal) / nominal_bitrate +
           (data > 0 ? static_cast<double>(data) / data_bitrate : 0.0);
  }
  friend constexpr bool operator==(const FrameBits&, const FrameBits&) = default;
};

// Worst-case stuff bits over `stuffed_bits` dynamically stuffed bits (see above).
constexpr std::uint32_t worst_case_stuff_bits(std::uint32_t stuffed_bits) noexcept {
  return stuffed_bits == 0 ? 0 : (stuffed_bits - 1) / 4;
}

// ---- classic CAN -------------------------------------------------------------------------
inline constexpr std::uint32_t kFrameTailBits = 13;  // CRC delim, ACK, ACK delim, EOF 7, IFS 3

constexpr FrameBits classic_frame_bits(std::uint8_t data_bytes,
                                       Stuffing stuffing = Stuffing::kWorstCase) noexcept {
  const std::uint32_t n = data_bytes > kClassicMaxBytes ? kClassicMaxBytes : data_bytes;
  const std::uint32_t stuffed = 34 + 8 * n;
  const std::uint32_t stuff = stuffing == Stuffing::kWorstCase ? worst_case_stuff_bits(stuffed) : 0;
  return FrameBits{stuffed + stuff + kFrameTailBits, 0};
}
constexpr FrameBits classic_extended_frame_bits(std::uint8_t data_bytes,
                                                Stuffing stuffing = Stuffing::kWorstCase) noexcept {
  const std::uint32_t n = data_bytes > kClassicMaxBytes ? kClassicMaxBytes : data_bytes;
  const std::uint32_t stuffed = 54 + 8 * n;
  const std::uint32_t stuff = stuffing == Stuffing::kWorstCase ? worst_case_stuff_bits(stuffed) : 0;
  return FrameBits{stuffed + stuff + kFrameTailBits, 0};
}

// ---- CAN FD -------------------------------------------------------------------------------
// Frame sizes and DLC codes: firmware_if/can_frame.hpp (kFdDlcBytes, fd_frame_bytes,
// fd_dlc_code).
inline constexpr std::uint32_t kFdArbitrationBits = 17;      // SOF..BRS
inline constexpr std::uint32_t kFdArbitrationStuffBits = 3;  // worst case before the switch

constexpr std::uint32_t fd_crc_bits(std::uint8_t frame_bytes) noexcept {
  return frame_bytes <= 16 ? 17 : 21;
}
// Stuff count + fixed stuff bits + CRC sequence: 27 (CRC-17) or 32 (CRC-21).
constexpr std::uint32_t fd_crc_field_bits(std::uint8_t frame_bytes) noexcept {
  const std::uint32_t coded = 4 + fd_crc_bits(frame_bytes);
  return coded + 1 + (coded - 1) / 4;
}

// An FD base frame carrying `payload_bytes` (rounded up to the next DLC size). Without the
// bit-rate switch the data phase runs at the nominal rate and counts there.
constexpr FrameBits fd_frame_bits(std::uint8_t payload_bytes,
                                  Stuffing stuffing = Stuffing::kWorstCase,
                                  bool bit_rate_switch = true) noexcept {
  const std::uint32_t n = fd_frame_bytes(payload_bytes);
  const std::uint32_t dynamic = worst_case_stuff_bits(22 + 8 * n);
  const bool worst = stuffing == Stuffing::kWorstCase;
  FrameBits b;
  b.nominal = kFdArbitrationBits + kFrameTailBits + (worst ? kFdArbitrationStuffBits : 0);
  b.data = 5 + 8 * n + fd_crc_field_bits(static_cast<std::uint8_t>(n)) +
           (worst ? dynamic - kFdArbitrationStuffBits : 0);
  if (!bit_rate_switch) return FrameBits{b.nominal + b.data, 0};
  return b;
}

}  // namespace dualv::fw
