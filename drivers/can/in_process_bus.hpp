#pragma once
// An in-process CAN bus for deterministic unit tests and the in-process simulation.
//
// An InProcessHub owns N endpoints (InProcessBus, each a CanBus). A frame sent on one
// endpoint is delivered to every other endpoint, never back to the sender (as on a real
// bus with CAN_RAW_RECV_OWN_MSGS off). Each endpoint has a fixed-capacity receive ring;
// nothing is allocated after construction. There are no threads and no sleeping: the
// test owns time (set_time_ns) and every received frame is stamped with it, so runs are
// bit-for-bit repeatable. Not thread-safe: one thread drives the hub and all endpoints.
//
// Failure injection is per sending endpoint and counted in frames, so a test can say
// "drop the next 2 RPDOs the master sends" without touching the drive side:
//   fail_next_sends(n)  send() returns kWouldBlock n times (ENOBUFS), counted as tx_dropped
//   drop_next(n)        the next n accepted frames are lost on the wire (sender sees kOk)
//   corrupt_next(n, m)  the next n frames arrive with every data byte XORed with m
//   delay_next(n, k)    the next n frames arrive after k further frames have been delivered
//   force_bus_off()     the endpoint goes bus-off: send/receive return kBusOff until
//                       restart(); restart() discards its receive queue and its delayed
//                       frames still in flight (frames queued before the fault are never
//                       delivered late)
//   force_error_passive(on)  state() reports kErrorPassive; frames still pass
// Frames carry CAN FD as sent (fd, brs, up to 64 bytes); a frame a controller would refuse
// (fw::is_valid false) is refused with kIoError, counted as tx_dropped.
// The order of checks in send() is: bus-off, validity, fail_next_sends, then the frame is accepted
// (tx_frames) and drop, corrupt, delay apply in that order.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "drivers/can/can_bus.hpp"

namespace dualv::drivers {

class InProcessHub;

class InProcessBus final : public CanBus {
 public:
  InProcessBus(const InProcessBus&) = delete;
  InProcessBus& operator=(const InProcessBus&) = delete;

  // CanBus (real-time safe: noexcept, no allocation).
  BusStatus send(const fw::CanFrame& frame) noexcept override;
  BusStatus receive(fw::CanFrame& frame) noexcept override;
  BusStatus state() const noexcept override;
  BusStatus restart() noexcept override;
  const BusCounters& counters() const noexcept override { return counters_; }

  // Failure injection (test control). Calls replace the previous count.
  void fail_next_sends(std::size_t n) noexcept { fail_sends_ = n; }
  void drop_next(std::size_t n) noexcept { drop_ = n; }
  void corrupt_next(std::size_t n, std::uint8_t xor_mask = 0xFF) noexcept {
    corrupt_ = n;
    corrupt_mask_ = xor_mask;
  }
  void delay_next(std::size_t n, std::size_t k_frames) noexcept {
    delay_ = n;
    delay_frames_ = k_frames;
  }
  // Latches bus-off (counted once per transition). With refuse_restart, restart() keeps
  // failing with kBusOff until force_bus_off() is called again with false.
  void force_bus_off(bool refuse_restart = false) noexcept;
  void force_error_passive(bool on) noexcept;

  std::size_t index() const noexcept { return index_; }
  std::size_t pending() const noexcept { return rx_count_; }  // frames waiting in receive
  std::size_t capacity() const noexcept { return rx_.size(); }

 private:
  friend class InProcessHub;
  InProcessBus(InProcessHub& hub, std::size_t index, std::size_t capacity);
  void push(const fw::CanFrame& frame) noexcept;  // from the hub: into the receive ring

  InProcessHub& hub_;
  std::size_t index_;
  std::vector<fw::CanFrame> rx_;  // ring storage, sized once
  std::size_t rx_head_ = 0;
  std::size_t rx_count_ = 0;
  BusCounters counters_{};
  bool bus_off_ = false;
  bool refuse_restart_ = false;
  bool error_passive_ = false;
  std::size_t fail_sends_ = 0;
  std::size_t drop_ = 0;
  std::size_t corrupt_ = 0;
  std::uint8_t corrupt_mask_ = 0xFF;
  std::size_t delay_ = 0;
  std::size_t delay_frames_ = 0;
};

// Frames lost or altered by injection, for tests that assert on the wire, not the API.
struct InProcessHubStats {
  std::uint64_t delivered = 0;  // frames put on the wire (each counted once, not per receiver)
  std::uint64_t dropped = 0;    // drop_next
  std::uint64_t corrupted = 0;  // corrupt_next
  std::uint64_t delayed = 0;    // delay_next (counted when held back)
  std::uint64_t discarded_delayed = 0;  // delayed frames discarded by the sender's restart()
  std::uint64_t delay_overflows = 0;    // delay_next could not hold the frame back
};

class InProcessHub {
 public:
  // Set-up: throws std::invalid_argument if endpoints < 2 or capacities are 0.
  // queue_capacity: frames per endpoint receive ring (a full ring drops the new frame for
  // that receiver and counts rx_overruns, like a socket receive buffer); delay_capacity:
  // frames delay_next can hold back at once (beyond it a frame is delivered undelayed and
  // counted in stats().delay_overflows, so a test notices its plan did not apply).
  explicit InProcessHub(std::size_t endpoints, std::size_t queue_capacity = 256,
                        std::size_t delay_capacity = 64);
  InProcessHub(const InProcessHub&) = delete;
  InProcessHub& operator=(const InProcessHub&) = delete;
  ~InProcessHub();

  InProcessBus& endpoint(std::size_t i);  // throws std::out_of_range (set-up only)
  std::size_t size() const noexcept { return endpoints_.size(); }

  // The injected clock: every delivered frame gets timestamp_ns = now_ns().
  void set_time_ns(std::uint64_t now_ns) noexcept { now_ns_ = now_ns; }
  void advance_ns(std::uint64_t dt_ns) noexcept { now_ns_ += dt_ns; }
  std::uint64_t now_ns() const noexcept { return now_ns_; }

  // Delivers every delayed frame now, in the order they were sent.
  void release_delayed() noexcept;
  std::size_t delayed_count() const noexcept { return delayed_count_; }
  const InProcessHubStats& stats() const noexcept { return stats_; }

 private:
  friend class InProcessBus;
  struct Delayed {
    fw::CanFrame frame;
    std::size_t from = 0;
    std::size_t remaining = 0;  // frames still to be delivered before this one
  };
  void transmit(std::size_t from, const fw::CanFrame& frame, std::size_t delay) noexcept;
  void deliver(std::size_t from, const fw::CanFrame& frame) noexcept;
  void discard_delayed_from(std::size_t from) noexcept;
  void remove_delayed(std::size_t i) noexcept;

  std::vector<std::unique_ptr<InProcessBus>> endpoints_;
  std::vector<Delayed> delayed_;  // storage, sized once; [0, delayed_count_) in send order
  std::size_t delayed_count_ = 0;
  std::uint64_t now_ns_ = 0;
  InProcessHubStats stats_{};
};

}  // namespace dualv::drivers
