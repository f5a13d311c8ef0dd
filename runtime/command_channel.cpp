#include "runtime/command_channel.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <lcm/lcm-cpp.hpp>
#include <stdexcept>

#include "runtime/channels.hpp"
#include "runtime/telemetry.hpp"
#include "runtime/telemetry_publisher.hpp"

namespace dualv::runtime {

CommandChannel::CommandChannel(const std::string& url, CommandVerifier verifier, WallClock clock)
    : owned_(std::make_unique<lcm::LCM>(url)),
      lcm_(owned_.get()),
      verifier_(std::move(verifier)),
      clock_(clock ? std::move(clock) : WallClock(wall_utime)) {
  if (!lcm_->good())
    throw std::runtime_error(fmt::format(
        "cannot open LCM URL '{}' for commands: use a live URL such as {}", url, kLiveUrl));
  subscribe();
  if (!verifier_.state_note().empty()) spdlog::info("command channel: {}", verifier_.state_note());
}

CommandChannel::CommandChannel(lcm::LCM& lcm, CommandVerifier verifier, WallClock clock)
    : lcm_(&lcm),
      verifier_(std::move(verifier)),
      clock_(clock ? std::move(clock) : WallClock(wall_utime)) {
  subscribe();
  if (!verifier_.state_note().empty()) spdlog::info("command channel: {}", verifier_.state_note());
}

CommandChannel::~CommandChannel() {
  stop();
  // An LCM owned by the caller outlives us: it must not call back into a dead object.
  if (subscription_ != nullptr) lcm_unsubscribe(lcm_->getUnderlyingLCM(), subscription_);
  if (setpoint_subscription_ != nullptr)
    lcm_unsubscribe(lcm_->getUnderlyingLCM(), setpoint_subscription_);
}

void CommandChannel::subscribe() {
  subscription_ =
      lcm_subscribe(lcm_->getUnderlyingLCM(), kCommandChannel, &CommandChannel::on_message, this);
  if (subscription_ == nullptr)
    throw std::runtime_error(fmt::format("cannot subscribe to LCM channel {}", kCommandChannel));
  setpoint_subscription_ =
      lcm_subscribe(lcm_->getUnderlyingLCM(), kSetpointChannel, &CommandChannel::on_setpoint, this);
  if (setpoint_subscription_ == nullptr)
    throw std::runtime_error(fmt::format("cannot subscribe to LCM channel {}", kSetpointChannel));
}

int CommandChannel::poll(int timeout_ms) { return lcm_->handleTimeout(timeout_ms); }

void CommandChannel::start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] {
    while (running_.load(std::memory_order_acquire)) {
      if (poll(50) < 0) {
        spdlog::error("command channel: LCM receive failed; commands are no longer received");
        break;
      }
    }
  });
}

void CommandChannel::stop() {
  if (running_.exchange(false) && thread_.joinable()) thread_.join();
  log_summaries(clock_(), true);
}

void CommandChannel::log_summaries(std::int64_t now_us, bool force) {
  if (const auto n = refused_log_.take_summary(now_us, force)) {
    std::string by;
    for (int v = 1; v < kVerdictCount; ++v)
      if (const auto c = verifier_.count(static_cast<CommandVerdict>(v)))
        by += fmt::format("{}{} {}", by.empty() ? "" : ", ",
                          to_string(static_cast<CommandVerdict>(v)), c);
    spdlog::warn("command channel: {} more refused commands not logged ({} refused so far: {})", n,
                 refused_.load(), by);
  }
  if (const auto n = accepted_log_.take_summary(now_us, force))
    spdlog::info(
        "command channel: {} more accepted commands not logged ({} accepted so far, {} "
        "e-stops)",
        n, accepted_.load(), estops_.load());
  if (const auto n = queue_full_log_.take_summary(now_us, force))
    spdlog::error("command channel: {} more commands dropped on a full queue ({} dropped so far)",
                  n, queue_.dropped());
  if (const auto n = setpoint_log_.take_summary(now_us, force))
    spdlog::warn("command channel: {} more refused setpoints not logged ({} refused so far)", n,
                 sp_refused_.load());
}

void CommandChannel::on_message(const lcm_recv_buf_t* rbuf, const char*, void* user) {
  auto* self = static_cast<CommandChannel*>(user);
  // Called from LCM's C code: no exception may cross it.
  try {
    self->handle(rbuf->data, rbuf->data_size);
  } catch (const std::exception& e) {
    self->refused_.fetch_add(1);
    spdlog::error("command channel: {} while handling a command; it was not acted on", e.what());
  }
}

void CommandChannel::on_setpoint(const lcm_recv_buf_t* rbuf, const char*, void* user) {
  auto* self = static_cast<CommandChannel*>(user);
  try {
    self->handle_setpoint(rbuf->data, rbuf->data_size);
  } catch (const std::exception& e) {
    self->sp_refused_.fetch_add(1);
    spdlog::error("command channel: {} while handling a setpoint; it was not acted on", e.what());
  }
}

void CommandChannel::handle_setpoint(const void* data, std::size_t size) {
  const std::int64_t now = clock_();
  log_summaries(now, false);
  SetpointVerifyResult r = verifier_.verify_setpoint_encoded(data, size, now);
  if (r.verdict == CommandVerdict::kAccepted && setpoint_check_) {
    std::string why = setpoint_check_(r.setpoint.x, r.setpoint.y, r.setpoint.theta);
    if (!why.empty()) {
      r.verdict = CommandVerdict::kMalformed;
      r.reason = std::move(why);
    }
  }
  if (r.verdict != CommandVerdict::kAccepted) {
    // A bad stream repeats at its rate: the first ones, then a summary per second.
    const std::uint64_t n = sp_refused_.fetch_add(1) + 1;
    if (setpoint_log_.allow(now))
      spdlog::warn("setpoint refused ({}): {}; key '{}', sequence {} ({} refused so far)",
                   to_string(r.verdict), r.reason, r.setpoint.key_id, r.setpoint.sequence, n);
    return;
  }
  sp_accepted_.fetch_add(1);
  VerifiedSetpoint v;
  v.utime = r.setpoint.utime;
  v.sequence = r.setpoint.sequence;
  v.x = r.setpoint.x;
  v.y = r.setpoint.y;
  v.theta = r.setpoint.theta;
  // A full queue means nobody consumes setpoints (no stream running): the newest are dropped
  // and counted; the consumer only ever wants the latest anyway.
  setpoints_.try_push(v);
}

dualv_lcm::setpoint_t send_setpoint(lcm::LCM& lcm, double x, double y, double theta,
                                    std::int64_t sequence, const CommandKey* key) {
  dualv_lcm::setpoint_t sp = make_setpoint(x, y, theta, wall_utime(), sequence, key);
  if (lcm.publish(kSetpointChannel, &sp) != 0)
    throw std::runtime_error("LCM publish of a setpoint failed");
  return sp;
}

void CommandChannel::handle(const void* data, std::size_t size) {
  const std::int64_t now = clock_();
  log_summaries(now, false);
  const VerifyResult r = verifier_.verify_encoded(data, size, now);
  if (r.verdict != CommandVerdict::kAccepted) {
    refused_.fetch_add(1);
    if (refused_log_.allow(now))
      spdlog::warn("command refused ({}): {}; kind {}, key '{}', sequence {}", to_string(r.verdict),
                   r.reason, static_cast<int>(r.command.kind), r.command.key_id,
                   r.command.sequence);
    return;
  }
  accepted_.fetch_add(1);
  VerifiedCommand v;
  v.kind = static_cast<CommandKind>(r.command.kind);
  v.utime = r.command.utime;
  v.sequence = r.command.sequence;
  v.is_signed = !r.command.key_id.empty();
  copy_text(v.program, r.command.program);
  copy_text(v.key_id, r.command.key_id);
  if (v.kind == CommandKind::kEstop) estops_.fetch_add(1, std::memory_order_release);
  if (accepted_log_.allow(now)) spdlog::info("command accepted: {}", r.reason);
  if (!queue_.try_push(v) && queue_full_log_.allow(now))
    spdlog::error("command queue full: {} dropped (the application is not reading commands)",
                  to_string(v.kind));
}

dualv_lcm::command_t send_command(lcm::LCM& lcm, CommandKind kind, const std::string& program,
                                  const CommandKey* key) {
  const std::int64_t now = wall_utime();
  // Strictly increasing within this process even for two sends in the same
  // microsecond; across processes the wall clock keeps it increasing.
  static std::atomic<std::int64_t> last{0};
  std::int64_t seq = last.load();
  while (!last.compare_exchange_weak(seq, std::max(now, seq + 1))) {
  }
  seq = std::max(now, seq + 1);
  dualv_lcm::command_t cmd = make_command(kind, program, now, seq, key);
  if (lcm.publish(kCommandChannel, &cmd) != 0)
    throw std::runtime_error(fmt::format("LCM publish of the {} command failed", to_string(kind)));
  return cmd;
}

}  // namespace dualv::runtime
