#pragma once
// What a real-time target PC needs, checked from /sys, /proc, rlimits and
// `ip -details link show`: PREEMPT_RT kernel, isolated CPUs, rtprio and
// memlock limits, the CAN interface present, up and at the configured
// bitrate. Every item that is not OK says what to fix. Used by
// `dualv check-target`; the inputs are injectable so tests use a fake /sys.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace dualv::runtime {

enum class CheckStatus { kOk, kWarn, kFail };
const char* to_string(CheckStatus s) noexcept;

struct CheckItem {
  std::string name;
  CheckStatus status = CheckStatus::kOk;
  std::string detail;  // what was found
  std::string fix;     // what to do (empty when OK)
};

struct TargetReport {
  std::vector<CheckItem> items;
  // false when an item failed (or, with strict, when one only warned).
  bool ok(bool strict = false) const noexcept;
  std::string format() const;
};

struct Limit {
  std::uint64_t soft = 0;
  bool unlimited = false;
};

struct TargetCheckInput {
  std::string sysfs_root = "/sys";  // tests point these at a fake tree
  std::string uname_version;        // `uname -v`; empty: read it with uname(2)
  std::optional<Limit> rtprio;      // empty: getrlimit(RLIMIT_RTPRIO)
  std::optional<Limit> memlock;     // empty: getrlimit(RLIMIT_MEMLOCK)
  // The capabilities that bypass the limits: CAP_SYS_NICE for SCHED_FIFO,
  // CAP_IPC_LOCK for mlockall. Empty: read CapEff from /proc/self/status (root
  // in a container often lacks them, so euid 0 alone proves nothing).
  std::optional<bool> cap_sys_nice;
  std::optional<bool> cap_ipc_lock;
  int priority = 80;  // SCHED_FIFO priority the loop asks for
  std::string can_interface = "can0";
  std::int64_t can_bitrate = 1'000'000;
  std::optional<std::string> ip_details;  // `ip -details link show IFACE`; empty: run it
};

TargetReport check_target(const TargetCheckInput& in);

// Parses "bitrate N" and "can state S" out of `ip -details link show` output.
struct IpCanDetails {
  std::optional<std::int64_t> bitrate;
  std::optional<std::string> state;  // ERROR-ACTIVE, ERROR-PASSIVE, BUS-OFF, STOPPED ...
  std::optional<std::int64_t> restart_ms;
  bool vcan = false;
};
IpCanDetails parse_ip_details(const std::string& text);

}  // namespace dualv::runtime
