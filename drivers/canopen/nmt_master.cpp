#include "drivers/canopen/nmt_master.hpp"

namespace dualv::drivers::canopen {

BusStatus send_nmt(CanBus& bus, fw::NmtCommand command, std::uint8_t node) noexcept {
  const fw::Result<fw::CanFrame> f = fw::encode_nmt(command, node);
  if (!f) return BusStatus::kIoError;
  return bus.send(*f);
}

}  // namespace dualv::drivers::canopen
