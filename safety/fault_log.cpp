#include "safety/fault_log.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace dualv::safety {

const char* to_string(EventKind k) noexcept {
  switch (k) {
    case EventKind::kFault:
      return "fault";
    case EventKind::kStopReached:
      return "stop reached";
    case EventKind::kResetAccepted:
      return "reset accepted";
    case EventKind::kResetRefused:
      return "reset refused";
    case EventKind::kArmed:
      return "armed";
  }
  return "unknown";
}

namespace {

std::string fault_names(FaultSet set) {
  std::string out;
  for (int i = 0; i < kFaultCount; ++i)
    if ((set >> i) & 1u) {
      if (!out.empty()) out += ", ";
      out += to_string(static_cast<Fault>(i));
    }
  return out;
}

std::string json_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out;
}

}  // namespace

std::string describe(const FaultEvent& e) {
  switch (e.kind) {
    case EventKind::kFault: {
      std::string s = to_string(e.fault);
      if (e.drive >= 0) s += fmt::format(" drive {}", e.drive + 1);
      if (e.fault == Fault::kDriveFault && e.value >= 0x1000)
        s += fmt::format(": EMCY {:04X}h", static_cast<unsigned>(e.value));
      else if (e.fault == Fault::kDriveFault && e.value > 0)
        s += fmt::format(
            ": left Operation enabled ({})",
            drivers::to_string(static_cast<drivers::DriveState>(static_cast<int>(e.value))));
      else if (e.limit != 0.0 || e.value != 0.0)
        s += fmt::format(": {:.6g} (limit {:.6g})", e.value, e.limit);
      return s + fmt::format(" -> {}", to_string(e.reaction));
    }
    case EventKind::kResetRefused:
      return fmt::format("reset refused: still active: {}", fault_names(e.blocking));
    default:
      return to_string(e.kind);
  }
}

std::string to_json(const FaultEvent& e) {
  std::string torque;
  for (int i = 0; i < e.n && i < drivers::kMaxDrives; ++i)
    torque += fmt::format("{}{:.6g}", i ? "," : "", e.torque[static_cast<std::size_t>(i)]);
  return fmt::format(
      "{{\"cycle\":{},\"time_ns\":{},\"event\":\"{}\",\"cause\":\"{}\",\"reaction\":\"{}\","
      "\"drive\":{},\"latency_cycles\":{},\"value\":{:.9g},\"limit\":{:.9g},\"blocking\":\"{}\","
      "\"torque\":[{}],\"text\":\"{}\"}}",
      e.cycle, e.time_ns, to_string(e.kind), e.kind == EventKind::kFault ? to_string(e.fault) : "",
      to_string(e.reaction), e.drive, e.latency_cycles, e.value, e.limit,
      json_escape(fault_names(e.blocking)), torque, json_escape(describe(e)));
}

FaultLogWriter::FaultLogWriter(const std::string& path) : file_(std::fopen(path.c_str(), "a")) {
  if (!file_)
    throw std::runtime_error(
        fmt::format("cannot open the fault log {}: {}", path, std::strerror(errno)));
}

FaultLogWriter::~FaultLogWriter() {
  if (file_) std::fclose(file_);
}

void FaultLogWriter::write(const FaultEvent& e) {
  const std::string line = to_json(e);
  std::fprintf(file_, "%s\n", line.c_str());
}

std::string describe_faults(FaultSet faults) {
  std::string causes;
  for (int f = 0; f < kFaultCount; ++f)
    if (faults & bit(static_cast<Fault>(f)))
      causes += std::string(causes.empty() ? "" : ", ") + to_string(static_cast<Fault>(f));
  return causes;
}

}  // namespace dualv::safety
