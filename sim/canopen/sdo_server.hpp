#pragma once
// A CANopen slave's SDO server (CiA 301 7.2.4.3), like CANopenNode's CO_SDOserver: takes a
// request frame (600h + node), answers with one response frame (580h + node) against an
// ObjectDictionary. Expedited and segmented download and upload; every abort with the
// standard's code: 06020000h no object, 06090011h no sub-index, 06010002h read-only,
// 06010001h write-only, 06070012h / 06070013h wrong length, 05030000h toggle not
// alternated, 05040001h unknown command or a segment outside a transfer, and what the
// application's download hook returns (value checks, mapping rules). Options for a
// foreign drive's habits: segmented uploads of small objects, expedited uploads without
// size indication (e=1, s=0). noexcept, no allocation; testable with frames alone.
#include <array>
#include <cstdint>

#include "firmware_if/can_frame.hpp"
#include "firmware_if/sdo.hpp"
#include "sim/canopen/object_dictionary.hpp"

namespace dualv::sim::canopen {

// What the application (the drive) does behind the server.
class SdoServerHooks {
 public:
  // A download of `value` (masked to the entry's size) to `slot`: check it, store it, act on
  // it; 0, or the SDO abort code that refuses it.
  virtual std::uint32_t download(int slot, std::uint32_t value) noexcept = 0;
  // `slot` is about to be uploaded: refresh live values (position, statusword, ...).
  virtual void before_upload(int slot) noexcept = 0;

 protected:
  ~SdoServerHooks() = default;
};

struct SdoServerOptions {
  bool segmented_upload = false;     // answer every upload segmented (legal for <= 4 bytes)
  bool upload_without_size = false;  // expedited upload responses 42h + 4 bytes
};

class SdoServer {
 public:
  void configure(std::uint8_t node, const SdoServerOptions& options) noexcept {
    node_ = node;
    options_ = options;
  }
  // One request; true when `response` was filled (false: not an SDO request of this node,
  // a wrong DLC, or an abort from the client, which ends the transfer without an answer).
  bool on_request(const fw::CanFrame& request, ObjectDictionary& od, SdoServerHooks& hooks,
                  fw::CanFrame& response) noexcept;
  // Back to idle (NMT reset communication, reset node).
  void reset() noexcept { state_ = State::kIdle; }
  bool busy() const noexcept { return state_ != State::kIdle; }
  std::uint64_t aborts_sent() const noexcept { return aborts_sent_; }

 private:
  enum class State : std::uint8_t { kIdle, kDownload, kUpload };
  bool abort(std::uint16_t index, std::uint8_t sub, std::uint32_t code,
             fw::CanFrame& response) noexcept;
  bool answer(const fw::Result<fw::CanFrame>& f, fw::CanFrame& response) noexcept;

  std::uint8_t node_ = 1;
  SdoServerOptions options_{};
  State state_ = State::kIdle;
  int slot_ = -1;
  std::array<std::uint8_t, 16> rx_{};
  fw::SdoSegmentReceiver receiver_{std::span<std::uint8_t>(rx_)};
  std::array<std::uint8_t, 4> tx_{};
  fw::SdoSegmentSender sender_{};
  std::uint64_t aborts_sent_ = 0;
};

}  // namespace dualv::sim::canopen
