#pragma once
// SDO protocol (CiA 301 7.2.4.3), expedited and segmented transfer; block transfer is not
// supported (its command specifiers decode as kBadCommandSpecifier). The client (host)
// sends requests on 600h + node, the server (drive) answers on 580h + node. Byte 0 is the
// command specifier, bytes 1..2 the index (LE), byte 3 the subindex, bytes 4..7 data.
//
//   client -> server                       server -> client
//   download initiate  ccs=1  2xh          download initiate resp.  scs=3  60h
//   download segment   ccs=0  0xh/1xh      download segment resp.   scs=1  20h/30h
//   upload initiate    ccs=2  40h          upload initiate resp.    scs=2  4xh
//   upload segment     ccs=3  60h/70h      upload segment resp.     scs=0  0xh/1xh
//   abort              cs=4   80h          abort                    cs=4   80h
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "firmware_if/can_frame.hpp"
#include "firmware_if/object_dictionary.hpp"
#include "firmware_if/result.hpp"

namespace dualv::fw {

// CiA 301 7.2.4.3.17 table 22, SDO abort codes.
enum class SdoAbortCode : std::uint32_t {
  kToggleNotAlternated = 0x05030000,
  kTimeout = 0x05040000,
  kBadCommandSpecifier = 0x05040001,
  kInvalidBlockSize = 0x05040002,
  kInvalidSequenceNumber = 0x05040003,
  kCrcError = 0x05040004,
  kOutOfMemory = 0x05040005,
  kUnsupportedAccess = 0x06010000,
  kWriteOnly = 0x06010001,  // attempt to read a write-only object
  kReadOnly = 0x06010002,   // attempt to write a read-only object
  kObjectDoesNotExist = 0x06020000,
  kCannotBeMapped = 0x06040041,
  kMappingTooLong = 0x06040042,
  kParameterIncompatible = 0x06040043,
  kInternalIncompatible = 0x06040047,
  kHardwareError = 0x06060000,
  kLengthMismatch = 0x06070010,
  kLengthTooHigh = 0x06070012,
  kLengthTooLow = 0x06070013,
  kSubindexDoesNotExist = 0x06090011,
  kInvalidValue = 0x06090030,
  kValueTooHigh = 0x06090031,
  kValueTooLow = 0x06090032,
  kMaxLessThanMin = 0x06090036,
  kResourceNotAvailable = 0x060A0023,
  kGeneralError = 0x08000000,
  kCannotStore = 0x08000020,
  kCannotStoreLocalControl = 0x08000021,
  kCannotStoreDeviceState = 0x08000022,  // e.g. mapping written while Operational
  kNoObjectDictionary = 0x08000023,
  kNoDataAvailable = 0x08000024,
};
// Text per CiA 301 table 22; "unknown abort code" for codes not listed.
const char* sdo_abort_text(std::uint32_t code) noexcept;
inline const char* to_string(SdoAbortCode c) noexcept {
  return sdo_abort_text(static_cast<std::uint32_t>(c));
}

enum class SdoType : std::uint8_t {
  kDownloadInitiate,  // request: write starts; response: confirmed
  kDownloadSegment,   // request: 0..7 bytes; response: toggle echoed
  kUploadInitiate,    // request: read starts; response: expedited data or total size
  kUploadSegment,     // request: toggle; response: 0..7 bytes
  kAbort,
};

inline constexpr std::size_t kSdoExpeditedMax = 4;
inline constexpr std::size_t kSdoSegmentMax = 7;

// One decoded SDO frame, request or response (the direction is the decoder's).
struct SdoMessage {
  SdoType type = SdoType::kAbort;
  std::uint8_t node = 0;
  std::uint16_t index = 0;  // initiate and abort
  std::uint8_t subindex = 0;
  bool expedited = false;       // initiate: data carried in this frame (e bit)
  bool size_indicated = false;  // initiate: s bit
  std::uint32_t size = 0;       // segmented initiate with s: total bytes announced
  bool toggle = false;          // segments and segment responses (t bit)
  bool last = false;            // segment: no more segments (c bit)
  std::uint8_t data_len = 0;    // expedited (1..4) or segment (0..7) payload bytes
  std::array<std::uint8_t, kSdoSegmentMax> data{};
  std::uint32_t abort_code = 0;  // raw, so codes outside the enum stay visible

  // The expedited payload as an unsigned LE value (data_len <= 4 bytes).
  std::uint32_t value() const noexcept;
  std::span<const std::uint8_t> bytes() const noexcept { return {data.data(), data_len}; }
};

// ---- client (host) -> server (drive), COB-ID 600h + node ------------------------------
// All encoders: kBadNodeId for node outside 1..127, kTooLong for oversize payloads.
// Expedited download of 1..4 bytes, size indicated (23h/27h/2Bh/2Fh).
Result<CanFrame> sdo_download_expedited(std::uint8_t node, std::uint16_t index,
                                        std::uint8_t subindex,
                                        std::span<const std::uint8_t> bytes) noexcept;
// Expedited download of `raw` in the entry's size (e.g. 6072h u16: 2Bh 72h 60h 00h lo hi).
Result<CanFrame> sdo_download_value(std::uint8_t node, const OdEntry& entry,
                                    std::uint32_t raw) noexcept;
// Segmented download initiate, size indicated (21h + size u32 in bytes 4..7).
Result<CanFrame> sdo_download_initiate(std::uint8_t node, std::uint16_t index,
                                       std::uint8_t subindex, std::uint32_t size) noexcept;
// Download segment: 0..7 bytes, toggle starts at 0 and alternates, last sets c.
Result<CanFrame> sdo_download_segment(std::uint8_t node, bool toggle,
                                      std::span<const std::uint8_t> bytes, bool last) noexcept;
Result<CanFrame> sdo_upload_initiate(std::uint8_t node, std::uint16_t index,
                                     std::uint8_t subindex) noexcept;
Result<CanFrame> sdo_upload_segment_request(std::uint8_t node, bool toggle) noexcept;

// ---- server (drive) -> client (host), COB-ID 580h + node ------------------------------
Result<CanFrame> sdo_download_initiate_response(std::uint8_t node, std::uint16_t index,
                                                std::uint8_t subindex) noexcept;
Result<CanFrame> sdo_download_segment_response(std::uint8_t node, bool toggle) noexcept;
// Expedited upload response, 1..4 bytes, size indicated (43h/47h/4Bh/4Fh).
Result<CanFrame> sdo_upload_expedited_response(std::uint8_t node, std::uint16_t index,
                                               std::uint8_t subindex,
                                               std::span<const std::uint8_t> bytes) noexcept;
Result<CanFrame> sdo_upload_value_response(std::uint8_t node, const OdEntry& entry,
                                           std::uint32_t raw) noexcept;
// Segmented upload initiate response, size indicated (41h + size).
Result<CanFrame> sdo_upload_initiate_response(std::uint8_t node, std::uint16_t index,
                                              std::uint8_t subindex, std::uint32_t size) noexcept;
Result<CanFrame> sdo_upload_segment_response(std::uint8_t node, bool toggle,
                                             std::span<const std::uint8_t> bytes,
                                             bool last) noexcept;

// ---- either side -------------------------------------------------------------------------
enum class SdoRole : std::uint8_t { kClient, kServer };  // who sends the abort
Result<CanFrame> sdo_abort(std::uint8_t node, SdoRole sender, std::uint16_t index,
                           std::uint8_t subindex, std::uint32_t code) noexcept;
inline Result<CanFrame> sdo_abort(std::uint8_t node, SdoRole sender, std::uint16_t index,
                                  std::uint8_t subindex, SdoAbortCode code) noexcept {
  return sdo_abort(node, sender, index, subindex, static_cast<std::uint32_t>(code));
}

// ---- decoders ---------------------------------------------------------------------------
// Server side: frames on 600h + node. kWrongFunction, kWrongDlc (not 8: CiA 301 SDO
// frames are always 8 bytes), kBadCommandSpecifier (ccs 5..7, or a download segment /
// expedited size field that does not fit), kRemoteFrame, kUnknownCobId, kExtendedId.
Result<SdoMessage> decode_sdo_request(const CanFrame& frame) noexcept;
// Client side: frames on 580h + node; same errors.
Result<SdoMessage> decode_sdo_response(const CanFrame& frame) noexcept;
// Same, plus kWrongNode when the response is from another node than `expected_node`.
Result<SdoMessage> decode_sdo_response(const CanFrame& frame, std::uint8_t expected_node) noexcept;

// kToggleMismatch unless `m` is a segment (request or response) carrying `expected`.
Error check_toggle(const SdoMessage& m, bool expected) noexcept;

// Receiving half of a segmented transfer (client upload, server download) into a
// caller-owned buffer: checks toggle alternation (first segment 0), overflow of the buffer
// and, on the last segment, the announced size. No allocation.
class SdoSegmentReceiver {
 public:
  explicit SdoSegmentReceiver(std::span<std::uint8_t> buffer) noexcept : buffer_(buffer) {}
  // announced_size 0 = not indicated.
  void begin(std::uint32_t announced_size) noexcept;
  // kBadCommandSpecifier (not a segment), kToggleMismatch, kTooLong (buffer or announced
  // size exceeded), kSizeMismatch (last segment short of the announced size). After an
  // error the transfer is over: the caller aborts it (05030000h for a toggle mismatch).
  Error accept(const SdoMessage& segment) noexcept;
  bool expected_toggle() const noexcept { return toggle_; }
  bool done() const noexcept { return done_; }
  std::span<const std::uint8_t> bytes() const noexcept { return buffer_.first(size_); }

 private:
  std::span<std::uint8_t> buffer_;
  std::size_t size_ = 0;
  std::uint32_t announced_ = 0;
  bool toggle_ = false;
  bool done_ = false;
};

// Sending half (client download, server upload): cuts a caller-owned payload into 7-byte
// segments with alternating toggles. The payload must outlive the transfer.
class SdoSegmentSender {
 public:
  struct Segment {
    std::span<const std::uint8_t> bytes;
    bool toggle = false;
    bool last = false;
  };
  void begin(std::span<const std::uint8_t> payload) noexcept;
  // Toggle of the segment next() will return (a server checks the upload request with it).
  bool next_toggle() const noexcept { return toggle_; }
  // The next segment, advancing. After the last one done() is true and next() returns an
  // empty last segment.
  Segment next() noexcept;
  bool done() const noexcept { return done_; }

 private:
  std::span<const std::uint8_t> payload_;
  std::size_t offset_ = 0;
  bool toggle_ = false;
  bool done_ = false;
};

}  // namespace dualv::fw
