#include "firmware_if/sync.hpp"

#include "firmware_if/cob_id.hpp"

namespace dualv::fw {

Result<CanFrame> encode_sync(std::uint8_t counter) noexcept {
  if (counter > kSyncCounterOverflowMax) return Error::kBadValue;
  CanFrame f;
  f.id = kSyncCobId;
  f.dlc = counter == 0 ? 0 : 1;
  f.data[0] = counter;
  return f;
}

Result<Sync> decode_sync(const CanFrame& frame) noexcept {
  const Result<std::uint8_t> node = expect_function(frame, Function::kSync);
  if (!node) return node.error();
  if (frame.dlc == 0) return Sync{0};
  if (frame.dlc != 1) return Error::kWrongDlc;
  const std::uint8_t c = frame.data[0];
  if (c < kSyncCounterMin || c > kSyncCounterOverflowMax) return Error::kBadValue;
  return Sync{c};
}

}  // namespace dualv::fw
