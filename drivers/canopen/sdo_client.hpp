#pragma once
// Non-blocking SDO client for one server node (CiA 301 7.2.4.3): expedited and segmented
// download (write) and upload (read), one transfer at a time, with a per-request timeout
// and abort handling. Every response form CiA 301 allows a server is accepted: expedited
// upload with and without size indication, segmented upload with and without size, toggle
// checked on every segment, an abort with any multiplexer. No allocation: the caller owns the
// payload and receive buffers, which must outlive the transfer. noexcept throughout, so it may run
// in any thread; the blocking helper for set-up is CanopenMaster (drivers/canopen/master.hpp).
//
// Timeout: measured from the last request frame sent (initiate or segment); the transfer
// times out at exactly `timeout` after it (T - 1 ns: still busy). On timeout, on a
// protocol error and on cancel() the client sends an abort (05040000h "SDO protocol timed
// out", 05030000h toggle, ...) so the server is free again.
#include <cstddef>
#include <cstdint>
#include <span>

#include "drivers/can/can_bus.hpp"
#include "firmware_if/sdo.hpp"

namespace dualv::drivers::canopen {

enum class SdoStatus : std::uint8_t {
  kIdle = 0,
  kBusy,
  kDone,
  kAborted,   // the server aborted: abort_code() / abort_text()
  kTimeout,   // no answer within the timeout; we sent abort 05040000h
  kError,     // a protocol error on our side (bad response, toggle, size): we aborted
  kBusError,  // a request could not be sent
};
const char* to_string(SdoStatus s) noexcept;

class SdoClient {
 public:
  SdoClient() = default;
  SdoClient(std::uint8_t node, std::uint64_t timeout_ns) noexcept
      : node_(node), timeout_ns_(timeout_ns) {}
  void configure(std::uint8_t node, std::uint64_t timeout_ns) noexcept {
    node_ = node;
    timeout_ns_ = timeout_ns;
  }

  // Write `data` (1..4 bytes: expedited; more: segmented) to index/subindex. Returns kBusy,
  // or the failure (kError for an empty payload or while another transfer is busy).
  SdoStatus download(CanBus& bus, std::uint16_t index, std::uint8_t subindex,
                     std::span<const std::uint8_t> data, std::uint64_t now_ns) noexcept;
  // Read index/subindex into `buffer` (expedited or segmented, whichever the server picks).
  // `expected_size` (bytes, 0 = unknown) is the object's size from its data type: an
  // expedited response without size indication (e=1, s=0, CiA 301 7.2.4.3.6) carries
  // "unspecified" length, and the client takes expected_size bytes of it (unknown: the
  // buffer's size, at most 4).
  SdoStatus upload(CanBus& bus, std::uint16_t index, std::uint8_t subindex,
                   std::span<std::uint8_t> buffer, std::uint64_t now_ns,
                   std::size_t expected_size = 0) noexcept;
  // Takes a received frame. True when it was this client's (580h + node) and consumed.
  bool on_frame(CanBus& bus, const fw::CanFrame& frame, std::uint64_t now_ns) noexcept;
  // Checks the timeout; returns the current status.
  SdoStatus poll(CanBus& bus, std::uint64_t now_ns) noexcept;
  // Aborts a busy transfer (abort code `code`) and returns to kIdle.
  void cancel(CanBus& bus, std::uint32_t code = static_cast<std::uint32_t>(
                               fw::SdoAbortCode::kGeneralError)) noexcept;

  SdoStatus status() const noexcept { return status_; }
  bool busy() const noexcept { return status_ == SdoStatus::kBusy; }
  // Abort code received (kAborted) or sent (kTimeout, kError); 0 otherwise.
  std::uint32_t abort_code() const noexcept { return abort_code_; }
  // An abort from the server ends the transfer in progress whatever multiplexer it carries
  // (one transfer per SDO channel at a time, CiA 301 7.2.4.3.17; servers are seen to send
  // 0000h/00 in aborts of the segment phase): true when the received abort named another
  // object than the transfer's (drivers/canopen/README.md "SDO").
  bool abort_multiplexer_differed() const noexcept { return abort_mux_differed_; }
  const char* abort_text() const noexcept { return fw::sdo_abort_text(abort_code_); }
  // What went wrong for kError (e.g. kToggleMismatch, kSizeMismatch).
  fw::Error protocol_error() const noexcept { return protocol_error_; }
  // Bytes read by the last upload (valid after kDone).
  std::span<const std::uint8_t> uploaded() const noexcept { return buffer_.first(uploaded_); }
  std::uint8_t node() const noexcept { return node_; }
  std::uint16_t index() const noexcept { return index_; }
  std::uint8_t subindex() const noexcept { return subindex_; }
  std::uint64_t timeout_ns() const noexcept { return timeout_ns_; }
  // Responses received while idle or not matching the transfer (counted, ignored).
  std::uint64_t unexpected() const noexcept { return unexpected_; }

 private:
  enum class Phase : std::uint8_t {
    kNone,
    kDownloadInitiate,
    kDownloadSegment,
    kUploadInitiate,
    kUploadSegment
  };
  SdoStatus send_request(CanBus& bus, const fw::Result<fw::CanFrame>& f,
                         std::uint64_t now_ns) noexcept;
  SdoStatus send_next_segment(CanBus& bus, std::uint64_t now_ns) noexcept;
  void download_acknowledged(CanBus& bus, std::uint64_t now_ns) noexcept;
  void fail(CanBus& bus, SdoStatus status, std::uint32_t code, fw::Error e) noexcept;

  std::uint8_t node_ = 0;
  std::uint64_t timeout_ns_ = 0;
  SdoStatus status_ = SdoStatus::kIdle;
  Phase phase_ = Phase::kNone;
  std::uint16_t index_ = 0;
  std::uint8_t subindex_ = 0;
  std::uint64_t sent_ns_ = 0;
  std::uint32_t abort_code_ = 0;
  fw::Error protocol_error_ = fw::Error::kNone;
  fw::SdoSegmentSender sender_{};
  bool last_toggle_ = false;
  bool last_segment_ = false;
  std::span<std::uint8_t> buffer_{};
  fw::SdoSegmentReceiver receiver_{std::span<std::uint8_t>{}};
  std::size_t uploaded_ = 0;
  std::size_t expected_size_ = 0;
  bool abort_mux_differed_ = false;
  std::uint64_t unexpected_ = 0;
};

}  // namespace dualv::drivers::canopen
