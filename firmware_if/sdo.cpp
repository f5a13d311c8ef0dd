#include "firmware_if/sdo.hpp"

#include <algorithm>

#include "firmware_if/byte_order.hpp"
#include "firmware_if/cob_id.hpp"

namespace dualv::fw {

namespace {

// Command specifiers, bits 7..5 of byte 0 (CiA 301 7.2.4.3.3 .. 7.2.4.3.17).
enum : std::uint8_t {
  kCcsDownloadSegment = 0,
  kCcsDownloadInitiate = 1,
  kCcsUploadInitiate = 2,
  kCcsUploadSegment = 3,
  kScsUploadSegment = 0,
  kScsDownloadSegment = 1,
  kScsUploadInitiate = 2,
  kScsDownloadInitiate = 3,
  kCsAbort = 4,
};
constexpr std::uint8_t kToggleBit = 0x10;     // t, segments
constexpr std::uint8_t kExpeditedBit = 0x02;  // e, initiate
constexpr std::uint8_t kSizeBit = 0x01;       // s, initiate
constexpr std::uint8_t kLastBit = 0x01;       // c, segments
constexpr std::uint8_t cs_bits(std::uint8_t cs) noexcept {
  return static_cast<std::uint8_t>(cs << 5);
}

Result<CanFrame> frame_for(Function f, std::uint8_t node) noexcept {
  const Result<std::uint16_t> id = make_cob_id(f, node);
  if (!id) return id.error();
  CanFrame frame;
  frame.id = *id;
  frame.dlc = 8;  // SDO frames are always 8 bytes; unused bytes are 0 (reserved)
  return frame;
}

Result<CanFrame> with_multiplexer(Function f, std::uint8_t node, std::uint8_t command,
                                  std::uint16_t index, std::uint8_t subindex) noexcept {
  Result<CanFrame> r = frame_for(f, node);
  if (!r) return r;
  CanFrame frame = *r;
  frame.data[0] = command;
  put_u16_le(&frame.data[1], index);
  frame.data[3] = subindex;
  return frame;
}

// Expedited initiate (download request or upload response): n = 4 - size in bits 3..2.
Result<CanFrame> expedited(Function f, std::uint8_t cs, std::uint8_t node, std::uint16_t index,
                           std::uint8_t subindex, std::span<const std::uint8_t> bytes) noexcept {
  if (bytes.empty() || bytes.size() > kSdoExpeditedMax) return Error::kTooLong;
  const auto n = static_cast<std::uint8_t>(kSdoExpeditedMax - bytes.size());
  const auto command = static_cast<std::uint8_t>(cs_bits(cs) | (n << 2) | kExpeditedBit | kSizeBit);
  Result<CanFrame> r = with_multiplexer(f, node, command, index, subindex);
  if (!r) return r;
  CanFrame frame = *r;
  std::copy(bytes.begin(), bytes.end(), frame.data.begin() + 4);
  return frame;
}

Result<CanFrame> expedited_value(Function f, std::uint8_t cs, std::uint8_t node,
                                 const OdEntry& entry, std::uint32_t raw) noexcept {
  std::array<std::uint8_t, 4> b{};
  put_u32_le(b.data(), raw);
  const std::size_t size = entry.size();
  if (size == 0 || size > 4) return Error::kTooLong;
  // Bits above the entry's size are dropped; for signed entries they are the sign extension.
  return expedited(f, cs, node, entry.index, entry.subindex, std::span(b).first(size));
}

Result<CanFrame> segmented_initiate(Function f, std::uint8_t cs, std::uint8_t node,
                                    std::uint16_t index, std::uint8_t subindex,
                                    std::uint32_t size) noexcept {
  Result<CanFrame> r =
      with_multiplexer(f, node, static_cast<std::uint8_t>(cs_bits(cs) | kSizeBit), index, subindex);
  if (!r) return r;
  CanFrame frame = *r;
  put_u32_le(&frame.data[4], size);
  return frame;
}

// Segment (download request or upload response): n = 7 - size in bits 3..1.
Result<CanFrame> segment(Function f, std::uint8_t cs, std::uint8_t node, bool toggle,
                         std::span<const std::uint8_t> bytes, bool last) noexcept {
  if (bytes.size() > kSdoSegmentMax) return Error::kTooLong;
  Result<CanFrame> r = frame_for(f, node);
  if (!r) return r;
  CanFrame frame = *r;
  const auto n = static_cast<std::uint8_t>(kSdoSegmentMax - bytes.size());
  frame.data[0] = static_cast<std::uint8_t>(cs_bits(cs) | (toggle ? kToggleBit : 0) | (n << 1) |
                                            (last ? kLastBit : 0));
  std::copy(bytes.begin(), bytes.end(), frame.data.begin() + 1);
  return frame;
}

Result<CanFrame> toggle_only(Function f, std::uint8_t cs, std::uint8_t node, bool toggle) noexcept {
  Result<CanFrame> r = frame_for(f, node);
  if (!r) return r;
  CanFrame frame = *r;
  frame.data[0] = static_cast<std::uint8_t>(cs_bits(cs) | (toggle ? kToggleBit : 0));
  return frame;
}

void read_multiplexer(const CanFrame& f, SdoMessage& m) noexcept {
  m.index = get_u16_le(&f.data[1]);
  m.subindex = f.data[3];
}

// Initiate frame carrying e/s/n (download request, upload response).
void read_initiate(const CanFrame& f, SdoMessage& m) noexcept {
  read_multiplexer(f, m);
  const std::uint8_t b0 = f.data[0];
  m.expedited = (b0 & kExpeditedBit) != 0;
  m.size_indicated = (b0 & kSizeBit) != 0;
  if (m.expedited) {
    // e=1, s=0: size unspecified, all 4 bytes delivered (CiA 301 7.2.4.3.3).
    m.data_len = m.size_indicated ? static_cast<std::uint8_t>(4 - ((b0 >> 2) & 0x03u)) : 4;
    m.size = m.data_len;
    std::copy_n(f.data.begin() + 4, m.data_len, m.data.begin());
  } else if (m.size_indicated) {
    m.size = get_u32_le(&f.data[4]);
  }
}

void read_segment(const CanFrame& f, SdoMessage& m) noexcept {
  const std::uint8_t b0 = f.data[0];
  m.toggle = (b0 & kToggleBit) != 0;
  m.last = (b0 & kLastBit) != 0;
  m.data_len = static_cast<std::uint8_t>(kSdoSegmentMax - ((b0 >> 1) & 0x07u));
  std::copy_n(f.data.begin() + 1, m.data_len, m.data.begin());
}

Result<SdoMessage> decode(const CanFrame& frame, Function f, bool request) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, f);
  if (!node) return node.error();
  if (frame.dlc != 8) return Error::kWrongDlc;
  SdoMessage m;
  m.node = *node;
  const std::uint8_t cs = frame.data[0] >> 5;
  if (cs == kCsAbort) {
    m.type = SdoType::kAbort;
    read_multiplexer(frame, m);
    m.abort_code = get_u32_le(&frame.data[4]);
    return m;
  }
  if (request) {
    switch (cs) {
      case kCcsDownloadInitiate:
        m.type = SdoType::kDownloadInitiate;
        read_initiate(frame, m);
        break;
      case kCcsDownloadSegment:
        m.type = SdoType::kDownloadSegment;
        read_segment(frame, m);
        break;
      case kCcsUploadInitiate:
        m.type = SdoType::kUploadInitiate;
        read_multiplexer(frame, m);
        break;
      case kCcsUploadSegment:
        m.type = SdoType::kUploadSegment;
        m.toggle = (frame.data[0] & kToggleBit) != 0;
        break;
      default:
        return Error::kBadCommandSpecifier;  // 5, 6 block transfer; 7 undefined
    }
  } else {
    switch (cs) {
      case kScsDownloadInitiate:
        m.type = SdoType::kDownloadInitiate;
        read_multiplexer(frame, m);
        break;
      case kScsDownloadSegment:
        m.type = SdoType::kDownloadSegment;
        m.toggle = (frame.data[0] & kToggleBit) != 0;
        break;
      case kScsUploadInitiate:
        m.type = SdoType::kUploadInitiate;
        read_initiate(frame, m);
        break;
      case kScsUploadSegment:
        m.type = SdoType::kUploadSegment;
        read_segment(frame, m);
        break;
      default:
        return Error::kBadCommandSpecifier;
    }
  }
  return m;
}

struct AbortText {
  SdoAbortCode code;
  const char* text;
};
constexpr AbortText kAbortTexts[] = {
    {SdoAbortCode::kToggleNotAlternated, "toggle bit not alternated"},
    {SdoAbortCode::kTimeout, "SDO protocol timed out"},
    {SdoAbortCode::kBadCommandSpecifier, "client/server command specifier not valid or unknown"},
    {SdoAbortCode::kInvalidBlockSize, "invalid block size"},
    {SdoAbortCode::kInvalidSequenceNumber, "invalid sequence number"},
    {SdoAbortCode::kCrcError, "CRC error"},
    {SdoAbortCode::kOutOfMemory, "out of memory"},
    {SdoAbortCode::kUnsupportedAccess, "unsupported access to an object"},
    {SdoAbortCode::kWriteOnly, "attempt to read a write only object"},
    {SdoAbortCode::kReadOnly, "attempt to write a read only object"},
    {SdoAbortCode::kObjectDoesNotExist, "object does not exist in the object dictionary"},
    {SdoAbortCode::kCannotBeMapped, "object cannot be mapped to the PDO"},
    {SdoAbortCode::kMappingTooLong,
     "the number and length of the objects to be mapped would exceed PDO length"},
    {SdoAbortCode::kParameterIncompatible, "general parameter incompatibility reason"},
    {SdoAbortCode::kInternalIncompatible, "general internal incompatibility in the device"},
    {SdoAbortCode::kHardwareError, "access failed due to a hardware error"},
    {SdoAbortCode::kLengthMismatch,
     "data type does not match, length of service parameter does not match"},
    {SdoAbortCode::kLengthTooHigh,
     "data type does not match, length of service parameter too high"},
    {SdoAbortCode::kLengthTooLow, "data type does not match, length of service parameter too low"},
    {SdoAbortCode::kSubindexDoesNotExist, "sub-index does not exist"},
    {SdoAbortCode::kInvalidValue, "invalid value for parameter (download only)"},
    {SdoAbortCode::kValueTooHigh, "value of parameter written too high (download only)"},
    {SdoAbortCode::kValueTooLow, "value of parameter written too low (download only)"},
    {SdoAbortCode::kMaxLessThanMin, "maximum value is less than minimum value"},
    {SdoAbortCode::kResourceNotAvailable, "resource not available: SDO connection"},
    {SdoAbortCode::kGeneralError, "general error"},
    {SdoAbortCode::kCannotStore, "data cannot be transferred or stored to the application"},
    {SdoAbortCode::kCannotStoreLocalControl,
     "data cannot be transferred or stored to the application because of local control"},
    {SdoAbortCode::kCannotStoreDeviceState,
     "data cannot be transferred or stored to the application because of the present device "
     "state"},
    {SdoAbortCode::kNoObjectDictionary,
     "object dictionary dynamic generation fails or no object dictionary is present"},
    {SdoAbortCode::kNoDataAvailable, "no data available"},
};

}  // namespace

const char* sdo_abort_text(std::uint32_t code) noexcept {
  for (const AbortText& t : kAbortTexts)
    if (static_cast<std::uint32_t>(t.code) == code) return t.text;
  return "unknown abort code";
}

std::uint32_t SdoMessage::value() const noexcept {
  return get_uint_le(data.data(), std::min<std::size_t>(data_len, kSdoExpeditedMax));
}

Result<CanFrame> sdo_download_expedited(std::uint8_t node, std::uint16_t index,
                                        std::uint8_t subindex,
                                        std::span<const std::uint8_t> bytes) noexcept {
  return expedited(Function::kSdoRx, kCcsDownloadInitiate, node, index, subindex, bytes);
}
Result<CanFrame> sdo_download_value(std::uint8_t node, const OdEntry& entry,
                                    std::uint32_t raw) noexcept {
  return expedited_value(Function::kSdoRx, kCcsDownloadInitiate, node, entry, raw);
}
Result<CanFrame> sdo_download_initiate(std::uint8_t node, std::uint16_t index,
                                       std::uint8_t subindex, std::uint32_t size) noexcept {
  return segmented_initiate(Function::kSdoRx, kCcsDownloadInitiate, node, index, subindex, size);
}
Result<CanFrame> sdo_download_segment(std::uint8_t node, bool toggle,
                                      std::span<const std::uint8_t> bytes, bool last) noexcept {
  return segment(Function::kSdoRx, kCcsDownloadSegment, node, toggle, bytes, last);
}
Result<CanFrame> sdo_upload_initiate(std::uint8_t node, std::uint16_t index,
                                     std::uint8_t subindex) noexcept {
  return with_multiplexer(Function::kSdoRx, node, cs_bits(kCcsUploadInitiate), index, subindex);
}
Result<CanFrame> sdo_upload_segment_request(std::uint8_t node, bool toggle) noexcept {
  return toggle_only(Function::kSdoRx, kCcsUploadSegment, node, toggle);
}

Result<CanFrame> sdo_download_initiate_response(std::uint8_t node, std::uint16_t index,
                                                std::uint8_t subindex) noexcept {
  return with_multiplexer(Function::kSdoTx, node, cs_bits(kScsDownloadInitiate), index, subindex);
}
Result<CanFrame> sdo_download_segment_response(std::uint8_t node, bool toggle) noexcept {
  return toggle_only(Function::kSdoTx, kScsDownloadSegment, node, toggle);
}
Result<CanFrame> sdo_upload_expedited_response(std::uint8_t node, std::uint16_t index,
                                               std::uint8_t subindex,
                                               std::span<const std::uint8_t> bytes) noexcept {
  return expedited(Function::kSdoTx, kScsUploadInitiate, node, index, subindex, bytes);
}
Result<CanFrame> sdo_upload_value_response(std::uint8_t node, const OdEntry& entry,
                                           std::uint32_t raw) noexcept {
  return expedited_value(Function::kSdoTx, kScsUploadInitiate, node, entry, raw);
}
Result<CanFrame> sdo_upload_initiate_response(std::uint8_t node, std::uint16_t index,
                                              std::uint8_t subindex, std::uint32_t size) noexcept {
  return segmented_initiate(Function::kSdoTx, kScsUploadInitiate, node, index, subindex, size);
}
Result<CanFrame> sdo_upload_segment_response(std::uint8_t node, bool toggle,
                                             std::span<const std::uint8_t> bytes,
                                             bool last) noexcept {
  return segment(Function::kSdoTx, kScsUploadSegment, node, toggle, bytes, last);
}

Result<CanFrame> sdo_abort(std::uint8_t node, SdoRole sender, std::uint16_t index,
                           std::uint8_t subindex, std::uint32_t code) noexcept {
  const Function f = sender == SdoRole::kClient ? Function::kSdoRx : Function::kSdoTx;
  Result<CanFrame> r = with_multiplexer(f, node, cs_bits(kCsAbort), index, subindex);
  if (!r) return r;
  CanFrame frame = *r;
  put_u32_le(&frame.data[4], code);
  return frame;
}

Result<SdoMessage> decode_sdo_request(const CanFrame& frame) noexcept {
  return decode(frame, Function::kSdoRx, true);
}
Result<SdoMessage> decode_sdo_response(const CanFrame& frame) noexcept {
  return decode(frame, Function::kSdoTx, false);
}
Result<SdoMessage> decode_sdo_response(const CanFrame& frame, std::uint8_t expected_node) noexcept {
  Result<SdoMessage> r = decode_sdo_response(frame);
  if (r && r->node != expected_node) return Error::kWrongNode;
  return r;
}

Error check_toggle(const SdoMessage& m, bool expected) noexcept {
  if (m.type != SdoType::kDownloadSegment && m.type != SdoType::kUploadSegment)
    return Error::kBadCommandSpecifier;
  return m.toggle == expected ? Error::kNone : Error::kToggleMismatch;
}

void SdoSegmentReceiver::begin(std::uint32_t announced_size) noexcept {
  size_ = 0;
  announced_ = announced_size;
  toggle_ = false;
  done_ = false;
}

Error SdoSegmentReceiver::accept(const SdoMessage& segment) noexcept {
  if (done_) return Error::kBadCommandSpecifier;
  if (const Error e = check_toggle(segment, toggle_); e != Error::kNone) {
    done_ = true;
    return e;
  }
  const std::size_t new_size = size_ + segment.data_len;
  if (new_size > buffer_.size() || (announced_ != 0 && new_size > announced_)) {
    done_ = true;
    return Error::kTooLong;
  }
  std::copy_n(segment.data.begin(), segment.data_len,
              buffer_.begin() + static_cast<std::ptrdiff_t>(size_));
  size_ = new_size;
  toggle_ = !toggle_;
  if (segment.last) {
    done_ = true;
    if (announced_ != 0 && size_ != announced_) return Error::kSizeMismatch;
  }
  return Error::kNone;
}

void SdoSegmentSender::begin(std::span<const std::uint8_t> payload) noexcept {
  payload_ = payload;
  offset_ = 0;
  toggle_ = false;
  done_ = false;
}

SdoSegmentSender::Segment SdoSegmentSender::next() noexcept {
  if (done_) return Segment{{}, toggle_, true};
  const std::size_t n = std::min(kSdoSegmentMax, payload_.size() - offset_);
  Segment s{payload_.subspan(offset_, n), toggle_, offset_ + n >= payload_.size()};
  offset_ += n;
  toggle_ = !toggle_;
  done_ = s.last;
  return s;
}

}  // namespace dualv::fw
