#include "drivers/canopen/emcy_consumer.hpp"

namespace dualv::drivers::canopen {

bool EmcyConsumer::on_emcy(const fw::Emcy& emcy, std::uint64_t now_ns) noexcept {
  if (emcy.is_reset()) {
    active_ = false;
    ++resets_;
    return false;
  }
  last_ = emcy;
  last_ns_ = now_ns;
  active_ = true;
  ++raised_;
  return true;
}

const char* EmcyConsumer::last_text() const noexcept {
  return raised_ == 0 ? "none" : fw::emcy_text(last_.error_code);
}

}  // namespace dualv::drivers::canopen
