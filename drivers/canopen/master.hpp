#pragma once
// The CANopen master's blocking services for set-up (not real-time): NMT, SDO read/write
// with readable errors, and waiting for boot-up / NMT states. While it waits it keeps
// producing the master's heartbeat and tracks every node's heartbeat and EMCY, so a drive
// whose 1016h already watches the master never sees it silent.
//
// Errors throw CanopenError (what() names the node, the object and the reason, e.g.
//   "node 3: SDO write 6060h sub0 (modes of operation) = 10 aborted by the drive:
//    06090030h invalid value for parameter (download only)").
// Every wait is bounded by the clock (Clock) and done through a Waiter; nothing sleeps.
#include <cstdint>
#include <functional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "drivers/can/can_bus.hpp"
#include "drivers/canopen/clock.hpp"
#include "drivers/canopen/emcy_consumer.hpp"
#include "drivers/canopen/heartbeat_consumer.hpp"
#include "drivers/canopen/heartbeat_producer.hpp"
#include "drivers/canopen/sdo_client.hpp"
#include "drivers/canopen/waiter.hpp"
#include "firmware_if/nmt.hpp"
#include "firmware_if/object_dictionary.hpp"

namespace dualv::drivers::canopen {

class CanopenError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// An SDO transfer that failed; code() is the abort code (sent or received), 0 for bus errors.
class SdoError : public CanopenError {
 public:
  SdoError(const std::string& what, std::uint8_t node, std::uint16_t index, std::uint8_t sub,
           SdoStatus status, std::uint32_t code)
      : CanopenError(what), node_(node), index_(index), sub_(sub), status_(status), code_(code) {}
  std::uint8_t node() const noexcept { return node_; }
  std::uint16_t index() const noexcept { return index_; }
  std::uint8_t subindex() const noexcept { return sub_; }
  SdoStatus status() const noexcept { return status_; }
  std::uint32_t code() const noexcept { return code_; }

 private:
  std::uint8_t node_;
  std::uint16_t index_;
  std::uint8_t sub_;
  SdoStatus status_;
  std::uint32_t code_;
};

// A node did not boot / reach a state in time; nodes() lists the ones missing.
class BootTimeoutError : public CanopenError {
 public:
  BootTimeoutError(const std::string& what, std::vector<std::uint8_t> nodes)
      : CanopenError(what), nodes_(std::move(nodes)) {}
  const std::vector<std::uint8_t>& nodes() const noexcept { return nodes_; }

 private:
  std::vector<std::uint8_t> nodes_;
};

struct MasterConfig {
  std::uint8_t node_id = 127;                             // the master's heartbeat 700h + id
  std::uint64_t heartbeat_period_ns = 50'000'000;         // 0 = no heartbeat
  std::uint64_t sdo_timeout_ns = 100'000'000;             // per SDO request
  std::uint64_t node_heartbeat_timeout_ns = 150'000'000;  // for the nodes' heartbeats
};

class CanopenMaster {
 public:
  // The bus, clock and waiter must outlive the master.
  CanopenMaster(CanBus& bus, const Clock& clock, Waiter& waiter, const MasterConfig& config);

  // NMT module control; node 0 = all. Throws CanopenError when the frame cannot be sent.
  void nmt(fw::NmtCommand command, std::uint8_t node);

  // Expedited write/read of a typed entry; `raw` is the value's bit pattern in the entry's
  // size (i16 -1 is 0xFFFF). read() returns it zero-extended.
  void write(std::uint8_t node, const fw::OdEntry& entry, std::uint32_t raw);
  std::uint32_t read(std::uint8_t node, const fw::OdEntry& entry);
  // Any size (segmented above 4 bytes).
  void write_bytes(std::uint8_t node, std::uint16_t index, std::uint8_t sub,
                   std::span<const std::uint8_t> data);
  std::vector<std::uint8_t> read_bytes(std::uint8_t node, std::uint16_t index, std::uint8_t sub,
                                       std::size_t max_size = 256);

  // Waits until every node in `nodes` has sent a boot-up message since the call (or since
  // forget_boot_ups()); throws BootTimeoutError naming the ones that did not.
  void wait_boot_up(std::span<const std::uint8_t> nodes, std::uint64_t timeout_ns);
  // Waits until every node reports `state` in its heartbeat.
  void wait_state(std::span<const std::uint8_t> nodes, fw::NmtState state,
                  std::uint64_t timeout_ns);
  // Receives and dispatches frames until `deadline_ns` (returns early when nothing is left
  // and the waiter returns); keeps the heartbeat going.
  void service(std::uint64_t deadline_ns);

  // Bookkeeping per node (1..127).
  const HeartbeatConsumer& heartbeat(std::uint8_t node) const { return heartbeats_.at(node); }
  const EmcyConsumer& emcy(std::uint8_t node) const { return emcys_.at(node); }
  bool booted(std::uint8_t node) const { return booted_.at(node); }
  void forget_boot_ups() { booted_.assign(booted_.size(), false); }
  CanBus& bus() noexcept { return bus_; }
  const Clock& clock() const noexcept { return clock_; }
  const MasterConfig& config() const noexcept { return config_; }
  std::uint64_t foreign_frames() const noexcept { return foreign_; }

 private:
  void dispatch(const fw::CanFrame& frame);
  void pump();  // heartbeat producer + drain the receive queue
  // Set-up: pumps the bus until done(n) holds for every node or timeout_ns passes; returns
  // the nodes still not done.
  std::vector<std::uint8_t> wait_for_nodes(std::span<const std::uint8_t> nodes,
                                           std::uint64_t timeout_ns,
                                           const std::function<bool(std::uint8_t)>& done);
  void run_sdo(SdoClient& client, const std::string& what);

  CanBus& bus_;
  const Clock& clock_;
  Waiter& waiter_;
  MasterConfig config_;
  HeartbeatProducer producer_;
  std::vector<HeartbeatConsumer> heartbeats_;  // by node id (index 0 unused)
  std::vector<EmcyConsumer> emcys_;
  std::vector<bool> booted_;
  SdoClient* active_sdo_ = nullptr;
  std::uint64_t foreign_ = 0;
};

// "6060h sub0 (modes of operation)"
std::string describe(const fw::OdEntry& entry);

}  // namespace dualv::drivers::canopen
