#include "sim/canopen/emcy_producer.hpp"

#include "firmware_if/emcy.hpp"

namespace dualv::sim::canopen {

std::uint8_t error_register_bits(std::uint16_t code) noexcept {
  std::uint8_t r = fw::error_register::kGeneric;
  switch (code >> 12) {
    case 0x2:
      r |= fw::error_register::kCurrent;
      break;
    case 0x3:
      r |= fw::error_register::kVoltage;
      break;
    case 0x4:
      r |= fw::error_register::kTemperature;
      break;
    case 0x8:
      r |= fw::error_register::kCommunication;
      break;
    default:
      break;
  }
  return r;
}

std::uint8_t EmcyProducer::error_register() const noexcept {
  std::uint8_t r = 0;
  for (std::size_t k = 0; k < active_.size(); ++k)
    if (active_[k]) r |= error_register_bits(code_[k]);
  return r;
}

void EmcyProducer::emit(ObjectDictionary& od, std::uint16_t code, bool announce,
                        FrameSink& sink) noexcept {
  od.set(slot_, error_register());  // 1001h first: the EMCY carries it
  if (!announce) return;
  fw::Emcy e;
  e.node = node_;
  e.error_code = code;
  e.error_register = error_register();
  if (const fw::Result<fw::CanFrame> f = fw::encode_emcy(e)) {
    sink.send(*f);
    ++sent_;
  }
}

void EmcyProducer::raise(ObjectDictionary& od, int condition, std::uint16_t code, bool announce,
                         FrameSink& sink) noexcept {
  if (condition < 0 || condition >= kEmcyConditions) return;
  active_[static_cast<std::size_t>(condition)] = true;
  code_[static_cast<std::size_t>(condition)] = code;
  emit(od, code, announce, sink);
}

void EmcyProducer::clear(ObjectDictionary& od, int condition, bool announce,
                         FrameSink& sink) noexcept {
  if (!active(condition)) return;
  active_[static_cast<std::size_t>(condition)] = false;
  emit(od, fw::emcy::kNoError, announce, sink);
}

}  // namespace dualv::sim::canopen
