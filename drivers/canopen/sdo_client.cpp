#include "drivers/canopen/sdo_client.hpp"

#include <algorithm>

#include "drivers/canopen/clock.hpp"
#include "firmware_if/cob_id.hpp"

namespace dualv::drivers::canopen {

namespace {
constexpr std::uint32_t code(fw::SdoAbortCode c) noexcept { return static_cast<std::uint32_t>(c); }
}  // namespace

const char* to_string(SdoStatus s) noexcept {
  switch (s) {
    case SdoStatus::kIdle:
      return "idle";
    case SdoStatus::kBusy:
      return "busy";
    case SdoStatus::kDone:
      return "done";
    case SdoStatus::kAborted:
      return "aborted by the drive";
    case SdoStatus::kTimeout:
      return "timed out";
    case SdoStatus::kError:
      return "protocol error";
    case SdoStatus::kBusError:
      return "CAN send failed";
  }
  return "?";
}

SdoStatus SdoClient::send_request(CanBus& bus, const fw::Result<fw::CanFrame>& f,
                                  std::uint64_t now_ns) noexcept {
  if (!f) {
    protocol_error_ = f.error();
    status_ = SdoStatus::kError;
    phase_ = Phase::kNone;
    return status_;
  }
  if (bus.send(*f) != BusStatus::kOk) {
    status_ = SdoStatus::kBusError;
    phase_ = Phase::kNone;
    return status_;
  }
  sent_ns_ = now_ns;
  status_ = SdoStatus::kBusy;
  return status_;
}

void SdoClient::fail(CanBus& bus, SdoStatus status, std::uint32_t abort, fw::Error e) noexcept {
  const fw::Result<fw::CanFrame> f =
      fw::sdo_abort(node_, fw::SdoRole::kClient, index_, subindex_, abort);
  if (f) (void)bus.send(*f);
  status_ = status;
  abort_code_ = abort;
  protocol_error_ = e;
  phase_ = Phase::kNone;
}

SdoStatus SdoClient::download(CanBus& bus, std::uint16_t index, std::uint8_t subindex,
                              std::span<const std::uint8_t> data, std::uint64_t now_ns) noexcept {
  if (status_ == SdoStatus::kBusy) return SdoStatus::kError;  // the busy transfer goes on
  if (data.empty()) {
    protocol_error_ = fw::Error::kBadValue;
    status_ = SdoStatus::kError;
    return status_;
  }
  index_ = index;
  subindex_ = subindex;
  abort_code_ = 0;
  abort_mux_differed_ = false;
  protocol_error_ = fw::Error::kNone;
  uploaded_ = 0;
  if (data.size() <= fw::kSdoExpeditedMax) {
    phase_ = Phase::kDownloadInitiate;
    last_segment_ = true;  // nothing follows the initiate
    return send_request(bus, fw::sdo_download_expedited(node_, index, subindex, data), now_ns);
  }
  sender_.begin(data);
  last_segment_ = false;
  phase_ = Phase::kDownloadInitiate;
  return send_request(
      bus,
      fw::sdo_download_initiate(node_, index, subindex, static_cast<std::uint32_t>(data.size())),
      now_ns);
}

SdoStatus SdoClient::upload(CanBus& bus, std::uint16_t index, std::uint8_t subindex,
                            std::span<std::uint8_t> buffer, std::uint64_t now_ns,
                            std::size_t expected_size) noexcept {
  if (status_ == SdoStatus::kBusy) return SdoStatus::kError;
  index_ = index;
  subindex_ = subindex;
  expected_size_ = expected_size;
  abort_code_ = 0;
  abort_mux_differed_ = false;
  protocol_error_ = fw::Error::kNone;
  buffer_ = buffer;
  uploaded_ = 0;
  phase_ = Phase::kUploadInitiate;
  return send_request(bus, fw::sdo_upload_initiate(node_, index, subindex), now_ns);
}

// The server confirmed the last download frame: done after the final segment, else the next.
void SdoClient::download_acknowledged(CanBus& bus, std::uint64_t now_ns) noexcept {
  if (last_segment_) {
    status_ = SdoStatus::kDone;
    phase_ = Phase::kNone;
  } else {
    send_next_segment(bus, now_ns);
  }
}

SdoStatus SdoClient::send_next_segment(CanBus& bus, std::uint64_t now_ns) noexcept {
  const fw::SdoSegmentSender::Segment s = sender_.next();
  last_toggle_ = s.toggle;
  last_segment_ = s.last;
  phase_ = Phase::kDownloadSegment;
  return send_request(bus, fw::sdo_download_segment(node_, s.toggle, s.bytes, s.last), now_ns);
}

bool SdoClient::on_frame(CanBus& bus, const fw::CanFrame& frame, std::uint64_t now_ns) noexcept {
  if (frame.extended || frame.id != fw::cob_id(fw::Function::kSdoTx, node_)) return false;
  if (status_ != SdoStatus::kBusy) {
    ++unexpected_;
    return true;
  }
  const fw::Result<fw::SdoMessage> r = fw::decode_sdo_response(frame, node_);
  if (!r) {
    fail(bus, SdoStatus::kError, code(fw::SdoAbortCode::kBadCommandSpecifier), r.error());
    return true;
  }
  const fw::SdoMessage& m = *r;
  if (m.type == fw::SdoType::kAbort) {
    // Ends the transfer whatever its multiplexer (see abort_multiplexer_differed()).
    abort_mux_differed_ = m.index != index_ || m.subindex != subindex_;
    status_ = SdoStatus::kAborted;
    abort_code_ = m.abort_code;
    phase_ = Phase::kNone;
    return true;
  }
  const bool initiate = phase_ == Phase::kDownloadInitiate || phase_ == Phase::kUploadInitiate;
  if (initiate && (m.index != index_ || m.subindex != subindex_)) {
    // An answer about another object: not ours (a late answer to an earlier request).
    ++unexpected_;
    fail(bus, SdoStatus::kError, code(fw::SdoAbortCode::kGeneralError), fw::Error::kBadValue);
    return true;
  }
  switch (phase_) {
    case Phase::kDownloadInitiate:
      if (m.type != fw::SdoType::kDownloadInitiate) break;
      download_acknowledged(bus, now_ns);
      return true;
    case Phase::kDownloadSegment:
      if (m.type != fw::SdoType::kDownloadSegment) break;
      if (m.toggle != last_toggle_) {
        fail(bus, SdoStatus::kError, code(fw::SdoAbortCode::kToggleNotAlternated),
             fw::Error::kToggleMismatch);
        return true;
      }
      download_acknowledged(bus, now_ns);
      return true;
    case Phase::kUploadInitiate:
      if (m.type != fw::SdoType::kUploadInitiate) break;
      if (m.expedited) {
        // e=1, s=0: the length is unspecified (4 data bytes on the wire, CiA 301 7.2.4.3.6);
        // the object's own size says how many of them are the value.
        std::size_t len = m.data_len;
        if (!m.size_indicated)
          len = (expected_size_ >= 1 && expected_size_ <= fw::kSdoExpeditedMax)
                    ? expected_size_
                    : std::min(buffer_.size(), fw::kSdoExpeditedMax);
        if (len > buffer_.size()) {
          fail(bus, SdoStatus::kError, code(fw::SdoAbortCode::kLengthTooHigh), fw::Error::kTooLong);
          return true;
        }
        std::copy_n(m.data.begin(), len, buffer_.begin());
        uploaded_ = len;
        status_ = SdoStatus::kDone;
        phase_ = Phase::kNone;
        return true;
      }
      if (m.size_indicated && m.size > buffer_.size()) {
        fail(bus, SdoStatus::kError, code(fw::SdoAbortCode::kLengthTooHigh), fw::Error::kTooLong);
        return true;
      }
      receiver_ = fw::SdoSegmentReceiver(buffer_);
      receiver_.begin(m.size_indicated ? m.size : 0);
      phase_ = Phase::kUploadSegment;
      send_request(bus, fw::sdo_upload_segment_request(node_, receiver_.expected_toggle()), now_ns);
      return true;
    case Phase::kUploadSegment: {
      if (m.type != fw::SdoType::kUploadSegment) break;
      const fw::Error e = receiver_.accept(m);
      if (e != fw::Error::kNone) {
        const std::uint32_t c =
            e == fw::Error::kToggleMismatch ? code(fw::SdoAbortCode::kToggleNotAlternated)
            : e == fw::Error::kTooLong      ? code(fw::SdoAbortCode::kLengthTooHigh)
                                            : code(fw::SdoAbortCode::kLengthMismatch);
        fail(bus, SdoStatus::kError, c, e);
        return true;
      }
      uploaded_ = receiver_.bytes().size();
      if (receiver_.done()) {
        status_ = SdoStatus::kDone;
        phase_ = Phase::kNone;
      } else {
        send_request(bus, fw::sdo_upload_segment_request(node_, receiver_.expected_toggle()),
                     now_ns);
      }
      return true;
    }
    case Phase::kNone:
      break;
  }
  fail(bus, SdoStatus::kError, code(fw::SdoAbortCode::kBadCommandSpecifier),
       fw::Error::kBadCommandSpecifier);
  return true;
}

SdoStatus SdoClient::poll(CanBus& bus, std::uint64_t now_ns) noexcept {
  if (status_ == SdoStatus::kBusy && expired(sent_ns_, now_ns, timeout_ns_))
    fail(bus, SdoStatus::kTimeout, code(fw::SdoAbortCode::kTimeout), fw::Error::kNone);
  return status_;
}

void SdoClient::cancel(CanBus& bus, std::uint32_t abort) noexcept {
  if (status_ == SdoStatus::kBusy) fail(bus, SdoStatus::kIdle, abort, fw::Error::kNone);
  status_ = SdoStatus::kIdle;
}

}  // namespace dualv::drivers::canopen
