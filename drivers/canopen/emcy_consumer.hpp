#pragma once
// EMCY consumer for one node (CiA 301 7.2.7): decoded emergency messages with readable text
// (fw::emcy_text). Error code 0000h ("error reset / no error") clears the active error and
// is never reported as a new one (docs/architecture.md users #6). Real-time safe.
#include <cstdint>

#include "firmware_if/emcy.hpp"

namespace dualv::drivers::canopen {

class EmcyConsumer {
 public:
  // True when the message raised an error (code != 0000h); false when it cleared one.
  bool on_emcy(const fw::Emcy& emcy, std::uint64_t now_ns) noexcept;

  bool active() const noexcept { return active_; }
  // The error now active: code 0 when none or cleared.
  std::uint16_t active_code() const noexcept { return active_ ? last_.error_code : 0; }
  // The last error raised (kept after a reset, for health and logs); code 0 if never.
  const fw::Emcy& last() const noexcept { return last_; }
  const char* last_text() const noexcept;
  std::uint64_t last_ns() const noexcept { return last_ns_; }
  std::uint64_t raised() const noexcept { return raised_; }
  std::uint64_t resets() const noexcept { return resets_; }

 private:
  fw::Emcy last_{};
  std::uint64_t last_ns_ = 0;
  bool active_ = false;
  std::uint64_t raised_ = 0;
  std::uint64_t resets_ = 0;
};

}  // namespace dualv::drivers::canopen
