#pragma once
// Error values for every firmware_if decoder. Decoders never throw and never allocate:
// they return Result<T> (a value or an Error) or a bare Error (kNone = success).
#include <cstdint>

namespace dualv::fw {

enum class Error : std::uint8_t {
  kNone = 0,
  kWrongDlc,             // data length does not match the protocol or the PDO layout
  kUnknownCobId,         // identifier outside the CiA 301 predefined connection set
  kWrongFunction,        // a valid COB-ID, but not the one this decoder handles
  kWrongNode,            // a valid COB-ID for another node than the one expected
  kBadNodeId,            // node id outside 1..127 (0 allowed only where CiA 301 says "all")
  kExtendedId,           // 29-bit frame: the CiA 301 predefined set is 11-bit only
  kRemoteFrame,          // RTR frame where a data frame is required
  kBadCommandSpecifier,  // SDO command byte not valid (includes block transfer, unsupported)
  kToggleMismatch,       // SDO segment toggle bit not alternated (CiA 301 7.2.4.3.4)
  kBadValue,             // a field holds a value the protocol does not define
  kTooLong,              // payload larger than the frame or the caller's buffer
  kSizeMismatch,         // segmented transfer ended with a byte count other than announced
};

// Static text, for logs and the CLI; never allocates.
const char* to_string(Error e) noexcept;

// A value or an error: the expected-like return of every decoder (std::expected is C++23).
// T must be default-constructible and cheap to copy (all firmware_if values are).
template <class T>
class [[nodiscard]] Result {
 public:
  constexpr Result(const T& value) noexcept : value_(value) {}         // NOLINT: implicit by design
  constexpr Result(Error error) noexcept : value_{}, error_(error) {}  // NOLINT

  constexpr bool ok() const noexcept { return error_ == Error::kNone; }
  constexpr explicit operator bool() const noexcept { return ok(); }
  constexpr Error error() const noexcept { return error_; }
  // Precondition ok(); on an error result this is a default-constructed T, never UB.
  constexpr const T& value() const noexcept { return value_; }
  constexpr const T& operator*() const noexcept { return value_; }
  constexpr const T* operator->() const noexcept { return &value_; }

 private:
  T value_{};
  Error error_ = Error::kNone;
};

}  // namespace dualv::fw
