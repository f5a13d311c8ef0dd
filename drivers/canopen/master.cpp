#include "drivers/canopen/master.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "drivers/canopen/nmt_master.hpp"
#include "firmware_if/byte_order.hpp"
#include "firmware_if/cob_id.hpp"
#include "firmware_if/emcy.hpp"
#include "firmware_if/heartbeat.hpp"

namespace dualv::drivers::canopen {

std::string describe(const fw::OdEntry& e) {
  return fmt::format("{:04X}h sub{} ({})", e.index, e.subindex, e.name);
}

namespace {
std::string node_list(const std::vector<std::uint8_t>& nodes) {
  std::string s;
  for (std::uint8_t n : nodes) s += (s.empty() ? "" : ", ") + std::to_string(n);
  return s;
}
double seconds(std::uint64_t ns) { return static_cast<double>(ns) / 1e9; }
}  // namespace

CanopenMaster::CanopenMaster(CanBus& bus, const Clock& clock, Waiter& waiter,
                             const MasterConfig& config)
    : bus_(bus),
      clock_(clock),
      waiter_(waiter),
      config_(config),
      producer_(config.node_id, config.heartbeat_period_ns),
      heartbeats_(fw::kMaxNodeId + 1),
      emcys_(fw::kMaxNodeId + 1),
      booted_(fw::kMaxNodeId + 1, false) {
  for (std::uint8_t n = 1; n <= fw::kMaxNodeId; ++n)
    heartbeats_[n] = HeartbeatConsumer(n, config.node_heartbeat_timeout_ns);
}

void CanopenMaster::nmt(fw::NmtCommand command, std::uint8_t node) {
  pump();
  const BusStatus s = send_nmt(bus_, command, node);
  if (s != BusStatus::kOk)
    throw CanopenError(fmt::format("NMT {} to node {}: CAN send failed ({})",
                                   fw::to_string(command), node, to_string(s)));
}

void CanopenMaster::dispatch(const fw::CanFrame& frame) {
  const std::uint64_t now = clock_.now_ns();
  if (active_sdo_ != nullptr && active_sdo_->on_frame(bus_, frame, now)) return;
  const fw::Result<fw::CobIdInfo> info = fw::classify(frame);
  if (!info) {
    ++foreign_;
    return;
  }
  switch (info->function) {
    case fw::Function::kHeartbeat: {
      const fw::Result<fw::Heartbeat> hb = fw::decode_heartbeat(frame);
      if (!hb) {
        ++foreign_;
        return;
      }
      if (heartbeats_[hb->node].on_heartbeat(hb->state, now) == HeartbeatEvent::kBootUp)
        booted_[hb->node] = true;
      return;
    }
    case fw::Function::kEmcy: {
      const fw::Result<fw::Emcy> e = fw::decode_emcy(frame);
      if (e)
        emcys_[e->node].on_emcy(*e, now);
      else
        ++foreign_;
      return;
    }
    default:
      return;  // PDOs, SYNC, other SDO channels: not the set-up's business
  }
}

void CanopenMaster::pump() {
  if (config_.heartbeat_period_ns != 0) (void)producer_.poll(bus_, clock_.now_ns());
  fw::CanFrame f;
  while (bus_.receive(f) == BusStatus::kOk) dispatch(f);
}

void CanopenMaster::service(std::uint64_t deadline_ns) {
  pump();
  while (clock_.now_ns() < deadline_ns) {
    waiter_.wait_until(deadline_ns);
    pump();
  }
}

void CanopenMaster::run_sdo(SdoClient& client, const std::string& what) {
  active_sdo_ = &client;
  while (client.busy()) {
    pump();
    if (client.poll(bus_, clock_.now_ns()) != SdoStatus::kBusy) break;
    // Wake at the timeout at the latest (poll() then fails it).
    waiter_.wait_until(clock_.now_ns() + client.timeout_ns());
  }
  active_sdo_ = nullptr;
  const SdoStatus s = client.status();
  if (s == SdoStatus::kDone) return;
  std::string reason;
  switch (s) {
    case SdoStatus::kAborted:
      reason =
          fmt::format("aborted by the drive: {:08X}h {}", client.abort_code(), client.abort_text());
      break;
    case SdoStatus::kTimeout:
      reason = fmt::format(
          "no answer within {} s (SDO timeout, can.timeouts.sdo); is node {} on "
          "the bus and powered?",
          seconds(client.timeout_ns()), client.node());
      break;
    case SdoStatus::kError:
      reason = fmt::format("protocol error ({}), aborted with {:08X}h {}",
                           fw::to_string(client.protocol_error()), client.abort_code(),
                           client.abort_text());
      break;
    default:
      reason = fmt::format("{} (bus state {})", to_string(s), to_string(bus_.state()));
      break;
  }
  throw SdoError(fmt::format("node {}: {} {}", client.node(), what, reason), client.node(),
                 client.index(), client.subindex(), s, client.abort_code());
}

void CanopenMaster::write(std::uint8_t node, const fw::OdEntry& entry, std::uint32_t raw) {
  std::array<std::uint8_t, 4> b{};
  fw::put_u32_le(b.data(), raw);
  SdoClient c(node, config_.sdo_timeout_ns);
  pump();
  c.download(bus_, entry.index, entry.subindex, std::span(b).first(entry.size()), clock_.now_ns());
  run_sdo(c, fmt::format("SDO write {} = {}", describe(entry),
                         fw::is_signed(entry.type)
                             ? std::to_string(entry.size() == 1   ? static_cast<std::int8_t>(raw)
                                              : entry.size() == 2 ? static_cast<std::int16_t>(raw)
                                                                  : static_cast<std::int32_t>(raw))
                             : std::to_string(raw)));
}

std::uint32_t CanopenMaster::read(std::uint8_t node, const fw::OdEntry& entry) {
  std::array<std::uint8_t, 4> b{};
  SdoClient c(node, config_.sdo_timeout_ns);
  pump();
  c.upload(bus_, entry.index, entry.subindex, b, clock_.now_ns(), entry.size());
  const std::string what = fmt::format("SDO read {}", describe(entry));
  run_sdo(c, what);
  if (c.uploaded().size() != entry.size())
    throw SdoError(fmt::format("node {}: {} returned {} bytes, expected {}", node, what,
                               c.uploaded().size(), entry.size()),
                   node, entry.index, entry.subindex, SdoStatus::kError, 0);
  return fw::get_uint_le(b.data(), entry.size());
}

void CanopenMaster::write_bytes(std::uint8_t node, std::uint16_t index, std::uint8_t sub,
                                std::span<const std::uint8_t> data) {
  SdoClient c(node, config_.sdo_timeout_ns);
  pump();
  c.download(bus_, index, sub, data, clock_.now_ns());
  run_sdo(c, fmt::format("SDO write {:04X}h sub{} ({} bytes)", index, sub, data.size()));
}

std::vector<std::uint8_t> CanopenMaster::read_bytes(std::uint8_t node, std::uint16_t index,
                                                    std::uint8_t sub, std::size_t max_size) {
  std::vector<std::uint8_t> buffer(max_size);
  SdoClient c(node, config_.sdo_timeout_ns);
  pump();
  c.upload(bus_, index, sub, buffer, clock_.now_ns());
  run_sdo(c, fmt::format("SDO read {:04X}h sub{}", index, sub));
  buffer.resize(c.uploaded().size());
  return buffer;
}

std::vector<std::uint8_t> CanopenMaster::wait_for_nodes(
    std::span<const std::uint8_t> nodes, std::uint64_t timeout_ns,
    const std::function<bool(std::uint8_t)>& done) {
  const std::uint64_t deadline = clock_.now_ns() + timeout_ns;
  auto missing = [&] {
    std::vector<std::uint8_t> m;
    for (std::uint8_t n : nodes)
      if (!done(n)) m.push_back(n);
    return m;
  };
  pump();
  while (!missing().empty() && clock_.now_ns() < deadline) {
    waiter_.wait_until(deadline);
    pump();
  }
  return missing();
}

void CanopenMaster::wait_boot_up(std::span<const std::uint8_t> nodes, std::uint64_t timeout_ns) {
  const std::vector<std::uint8_t> m =
      wait_for_nodes(nodes, timeout_ns, [&](std::uint8_t n) { return booted_.at(n); });
  if (!m.empty())
    throw BootTimeoutError(
        fmt::format("node{} {} did not boot within {} s (no boot-up message 700h + id after NMT "
                    "reset; can.timeouts.boot): check power, wiring, node id and bitrate",
                    m.size() > 1 ? "s" : "", node_list(m), seconds(timeout_ns)),
        m);
}

void CanopenMaster::wait_state(std::span<const std::uint8_t> nodes, fw::NmtState state,
                               std::uint64_t timeout_ns) {
  const std::vector<std::uint8_t> m = wait_for_nodes(nodes, timeout_ns, [&](std::uint8_t n) {
    return heartbeats_.at(n).seen() && heartbeats_.at(n).state() == state;
  });
  if (!m.empty()) {
    std::string detail;
    for (std::uint8_t n : m)
      detail += fmt::format(
          "; node {}: {}", n,
          heartbeats_.at(n).seen() ? fw::to_string(heartbeats_.at(n).state()) : "no heartbeat");
    throw BootTimeoutError(
        fmt::format("node{} {} did not report NMT state {} within {} s{}", m.size() > 1 ? "s" : "",
                    node_list(m), fw::to_string(state), seconds(timeout_ns), detail),
        m);
  }
}

}  // namespace dualv::drivers::canopen
