#include "sim/canopen/sdo_server.hpp"

#include "firmware_if/byte_order.hpp"
#include "firmware_if/cob_id.hpp"

namespace dualv::sim::canopen {

namespace {
constexpr std::uint32_t code(fw::SdoAbortCode c) noexcept { return static_cast<std::uint32_t>(c); }
std::uint32_t length_abort(std::size_t got, std::size_t want) noexcept {
  return code(got > want ? fw::SdoAbortCode::kLengthTooHigh : fw::SdoAbortCode::kLengthTooLow);
}
}  // namespace

bool SdoServer::answer(const fw::Result<fw::CanFrame>& f, fw::CanFrame& response) noexcept {
  if (!f) return false;
  response = *f;
  return true;
}

bool SdoServer::abort(std::uint16_t index, std::uint8_t sub, std::uint32_t c,
                      fw::CanFrame& response) noexcept {
  state_ = State::kIdle;
  ++aborts_sent_;
  return answer(fw::sdo_abort(node_, fw::SdoRole::kServer, index, sub, c), response);
}

bool SdoServer::on_request(const fw::CanFrame& frame, ObjectDictionary& od, SdoServerHooks& hooks,
                           fw::CanFrame& response) noexcept {
  if (frame.extended || frame.id != fw::cob_id(fw::Function::kSdoRx, node_)) return false;
  const fw::Result<fw::SdoMessage> r = fw::decode_sdo_request(frame);
  if (!r) {
    if (r.error() == fw::Error::kBadCommandSpecifier)
      return abort(fw::get_u16_le(&frame.data[1]), frame.data[3],
                   code(fw::SdoAbortCode::kBadCommandSpecifier), response);
    return false;  // a wrong DLC is not an SDO request at all: ignored
  }
  const fw::SdoMessage& m = *r;
  // Finds (index, sub) for an initiate; -1 (and the abort in `response`) when missing.
  auto lookup = [&]() -> int {
    const int slot = od.find(m.index, m.subindex);
    if (slot < 0)
      abort(m.index, m.subindex,
            code(od.has_index(m.index) ? fw::SdoAbortCode::kSubindexDoesNotExist
                                       : fw::SdoAbortCode::kObjectDoesNotExist),
            response);
    return slot;
  };
  switch (m.type) {
    case fw::SdoType::kAbort:
      state_ = State::kIdle;
      return false;
    case fw::SdoType::kDownloadInitiate: {
      state_ = State::kIdle;
      const int slot = lookup();
      if (slot < 0) return true;
      const fw::OdEntry& e = od.entry(slot);
      if (e.access == fw::Access::kRo || e.access == fw::Access::kConst)
        return abort(m.index, m.subindex, code(fw::SdoAbortCode::kReadOnly), response);
      if (m.expedited) {
        if (m.size_indicated && m.data_len != e.size())
          return abort(m.index, m.subindex, length_abort(m.data_len, e.size()), response);
        const std::uint32_t a =
            hooks.download(slot, fw::get_uint_le(m.data.data(), e.size()) & mask_of(e));
        if (a != 0) return abort(m.index, m.subindex, a, response);
        return answer(fw::sdo_download_initiate_response(node_, m.index, m.subindex), response);
      }
      if (m.size_indicated && m.size != e.size())
        return abort(m.index, m.subindex, length_abort(m.size, e.size()), response);
      receiver_.begin(m.size_indicated ? m.size : 0);
      state_ = State::kDownload;
      slot_ = slot;
      return answer(fw::sdo_download_initiate_response(node_, m.index, m.subindex), response);
    }
    case fw::SdoType::kDownloadSegment: {
      if (state_ != State::kDownload)
        return abort(0, 0, code(fw::SdoAbortCode::kBadCommandSpecifier), response);
      const fw::OdEntry& e = od.entry(slot_);
      switch (receiver_.accept(m)) {
        case fw::Error::kNone:
          break;
        case fw::Error::kToggleMismatch:
          return abort(e.index, e.subindex, code(fw::SdoAbortCode::kToggleNotAlternated), response);
        case fw::Error::kTooLong:
          return abort(e.index, e.subindex, code(fw::SdoAbortCode::kLengthTooHigh), response);
        case fw::Error::kSizeMismatch:
          return abort(e.index, e.subindex, code(fw::SdoAbortCode::kLengthTooLow), response);
        default:
          return abort(e.index, e.subindex, code(fw::SdoAbortCode::kBadCommandSpecifier), response);
      }
      if (receiver_.done()) {
        state_ = State::kIdle;
        const auto bytes = receiver_.bytes();
        if (bytes.size() != e.size())
          return abort(e.index, e.subindex, length_abort(bytes.size(), e.size()), response);
        const std::uint32_t a =
            hooks.download(slot_, fw::get_uint_le(bytes.data(), bytes.size()) & mask_of(e));
        if (a != 0) return abort(e.index, e.subindex, a, response);
      }
      return answer(fw::sdo_download_segment_response(node_, m.toggle), response);
    }
    case fw::SdoType::kUploadInitiate: {
      state_ = State::kIdle;
      const int slot = lookup();
      if (slot < 0) return true;
      const fw::OdEntry& e = od.entry(slot);
      if (e.access == fw::Access::kWo)
        return abort(m.index, m.subindex, code(fw::SdoAbortCode::kWriteOnly), response);
      hooks.before_upload(slot);
      const std::uint32_t v = od.u(slot);
      if (options_.segmented_upload) {
        fw::put_u32_le(tx_.data(), v);
        sender_.begin(std::span<const std::uint8_t>(tx_.data(), e.size()));
        state_ = State::kUpload;
        slot_ = slot;
        return answer(fw::sdo_upload_initiate_response(node_, m.index, m.subindex, e.size()),
                      response);
      }
      if (options_.upload_without_size) {
        // e=1, s=0: four data bytes, the length left to the object's type.
        fw::CanFrame f;
        f.id = fw::cob_id(fw::Function::kSdoTx, node_);
        f.dlc = 8;
        f.data[0] = 0x42;
        fw::put_u16_le(&f.data[1], m.index);
        f.data[3] = m.subindex;
        fw::put_u32_le(&f.data[4], v & mask_of(e));
        response = f;
        return true;
      }
      return answer(fw::sdo_upload_value_response(node_, e, v), response);
    }
    case fw::SdoType::kUploadSegment: {
      if (state_ != State::kUpload)
        return abort(0, 0, code(fw::SdoAbortCode::kBadCommandSpecifier), response);
      const fw::OdEntry& e = od.entry(slot_);
      if (m.toggle != sender_.next_toggle())
        return abort(e.index, e.subindex, code(fw::SdoAbortCode::kToggleNotAlternated), response);
      const fw::SdoSegmentSender::Segment s = sender_.next();
      if (s.last) state_ = State::kIdle;
      return answer(fw::sdo_upload_segment_response(node_, s.toggle, s.bytes, s.last), response);
    }
  }
  return false;
}

}  // namespace dualv::sim::canopen
