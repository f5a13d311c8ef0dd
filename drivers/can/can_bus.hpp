#pragma once
// One small CAN bus interface with several backends (lely-core's CAN channel idea):
// SocketCanBus (drivers/can/socketcan_bus.hpp) on a real or virtual interface, and
// InProcessBus (drivers/can/in_process_bus.hpp) for deterministic unit tests and the
// in-process simulation. Every layer above is unaware which one it runs on.
//
// Real-time safe: send/receive are noexcept, non-blocking and allocate nothing.
#include <cstddef>
#include <cstdint>
#include <span>

#include "firmware_if/can_frame.hpp"

namespace dualv::drivers {

enum class BusStatus : std::uint8_t {
  kOk = 0,
  kWouldBlock,    // send: the transmit queue is full (ENOBUFS/EAGAIN); receive: nothing pending
  kBusOff,        // the controller went bus-off: latched until restart() succeeds
  kErrorPassive,  // error counters high; frames may still pass
  kIoError,       // any other OS error
  kClosed,
};

const char* to_string(BusStatus s) noexcept;

// Error-frame and traffic counters; every backend keeps them.
struct BusCounters {
  std::uint64_t tx_frames = 0;
  std::uint64_t rx_frames = 0;
  std::uint64_t tx_dropped = 0;    // send returned kWouldBlock or an error
  std::uint64_t error_frames = 0;  // error frames received (SocketCAN CAN_ERR_FLAG)
  std::uint64_t bus_off_events = 0;
  std::uint64_t error_passive_events = 0;  // transitions into error passive
  std::uint64_t rx_overruns = 0;           // frames lost before we read them (full receive queue)
  std::uint64_t restarts = 0;              // successful restart() calls
};

class CanBus {
 public:
  virtual ~CanBus() = default;
  // Queues one frame for transmission; never blocks.
  virtual BusStatus send(const fw::CanFrame& frame) noexcept = 0;
  // Takes one received frame if any (kWouldBlock when none); never blocks.
  virtual BusStatus receive(fw::CanFrame& frame) noexcept = 0;
  // Queues frames in order, stopping at the first that cannot be queued: returns how many
  // were queued, and sets `status` to kOk or to why frames[returned] was not. One syscall
  // for the whole batch where the backend can (SocketCanBus: sendmmsg), so a cycle's SYNC
  // and RPDOs cost one kernel entry; the default sends one by one.
  virtual std::size_t send_many(std::span<const fw::CanFrame> frames, BusStatus& status) noexcept;
  // Takes up to frames.size() received frames: returns how many, and sets `status` to kOk,
  // kWouldBlock (fewer were pending) or the error that stopped it. SocketCanBus: recvmmsg.
  virtual std::size_t receive_many(std::span<fw::CanFrame> frames, BusStatus& status) noexcept;
  // Current controller state (kOk, kErrorPassive or kBusOff).
  virtual BusStatus state() const noexcept = 0;
  // Leaves bus-off: frames queued before the fault are discarded, never sent late.
  virtual BusStatus restart() noexcept = 0;
  virtual const BusCounters& counters() const noexcept = 0;
};

}  // namespace dualv::drivers
