#include "runtime/target_check.hpp"

#include <fmt/format.h>
#include <sys/resource.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <array>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>

namespace dualv::runtime {

namespace {

std::optional<std::string> read_trimmed(const std::string& path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  std::stringstream ss;
  ss << in.rdbuf();
  std::string s = ss.str();
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ' || s.back() == '\t')) s.pop_back();
  return s;
}

Limit get_limit(int resource) {
  rlimit rl{};
  getrlimit(resource, &rl);
  Limit l;
  l.unlimited = rl.rlim_cur == RLIM_INFINITY;
  l.soft = l.unlimited ? 0 : static_cast<std::uint64_t>(rl.rlim_cur);
  return l;
}

std::string run_command(const std::string& cmd) {
  std::string out;
  if (FILE* p = popen(cmd.c_str(), "r")) {
    std::array<char, 512> buf{};
    while (fgets(buf.data(), static_cast<int>(buf.size()), p) != nullptr) out += buf.data();
    pclose(p);
  }
  return out;
}

// CapEff of this process (0 when unreadable: then only the limits count).
std::uint64_t effective_capabilities() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("CapEff:", 0) == 0) return std::strtoull(line.c_str() + 7, nullptr, 16);
  return 0;
}

bool safe_ifname(const std::string& s) {
  // Only what Linux allows in an interface name we pass to a shell.
  if (s.empty() || s.size() > 15) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.'))
      return false;
  return true;
}

void add(TargetReport& r, std::string name, CheckStatus st, std::string detail,
         std::string fix = {}) {
  r.items.push_back(CheckItem{std::move(name), st, std::move(detail), std::move(fix)});
}

}  // namespace

const char* to_string(CheckStatus s) noexcept {
  switch (s) {
    case CheckStatus::kOk:
      return "OK";
    case CheckStatus::kWarn:
      return "WARN";
    case CheckStatus::kFail:
      return "FAIL";
  }
  return "?";
}

bool TargetReport::ok(bool strict) const noexcept {
  for (const auto& i : items)
    if (i.status == CheckStatus::kFail || (strict && i.status == CheckStatus::kWarn)) return false;
  return true;
}

std::string TargetReport::format() const {
  std::string out;
  for (const auto& i : items) {
    out += fmt::format("[{:<4}] {}: {}\n", to_string(i.status), i.name, i.detail);
    if (!i.fix.empty()) out += fmt::format("       fix: {}\n", i.fix);
  }
  return out;
}

IpCanDetails parse_ip_details(const std::string& text) {
  IpCanDetails d;
  std::smatch m;
  if (std::regex_search(text, m, std::regex(R"(\bbitrate (\d+))"))) d.bitrate = std::stoll(m[1]);
  if (std::regex_search(text, m, std::regex(R"(\bcan (?:<[^>]*> )?state ([A-Z-]+))")))
    d.state = m[1];
  if (std::regex_search(text, m, std::regex(R"(\brestart-ms (\d+))")))
    d.restart_ms = std::stoll(m[1]);
  d.vcan = std::regex_search(text, std::regex(R"(\n\s+vcan\b)"));
  return d;
}

TargetReport check_target(const TargetCheckInput& in) {
  TargetReport r;
  const std::string& sys = in.sysfs_root;

  // --- PREEMPT_RT kernel: /sys/kernel/realtime is 1 on RT kernels, and
  // `uname -v` carries "PREEMPT_RT" (older: "PREEMPT RT").
  std::string version = in.uname_version;
  if (version.empty()) {
    utsname u{};
    if (uname(&u) == 0) version = u.version;
  }
  const auto rt_flag = read_trimmed(sys + "/kernel/realtime");
  const bool rt = (rt_flag && *rt_flag == "1") || version.find("PREEMPT_RT") != std::string::npos ||
                  version.find("PREEMPT RT") != std::string::npos;
  if (rt)
    add(r, "PREEMPT_RT kernel", CheckStatus::kOk, version);
  else
    add(r, "PREEMPT_RT kernel", CheckStatus::kFail,
        fmt::format("not a real-time kernel ({})", version.empty() ? "unknown" : version),
        "install and boot a PREEMPT_RT kernel (Debian: apt install linux-image-rt-amd64); "
        "a 1 kHz loop on a standard kernel sees ms-scale latency spikes");

  // --- Isolated CPUs: recommended, not required.
  const auto iso = read_trimmed(sys + "/devices/system/cpu/isolated");
  if (iso && !iso->empty())
    add(r, "isolated CPUs", CheckStatus::kOk,
        fmt::format("{} (pin the loop there: loop.cpu in dualv.yaml, CPUAffinity= in the service)",
                    *iso));
  else
    add(r, "isolated CPUs", CheckStatus::kWarn, "none",
        "add isolcpus=3 nohz_full=3 rcu_nocbs=3 (pick a CPU) to the kernel command line "
        "(GRUB_CMDLINE_LINUX in /etc/default/grub, then update-grub) and set loop.cpu: 3");

  // --- rtprio and memlock of this process (the service sets its own limits).
  const std::uint64_t caps = effective_capabilities();
  const bool nice_cap = in.cap_sys_nice.value_or(((caps >> 23) & 1U) != 0);  // CAP_SYS_NICE
  const bool lock_cap = in.cap_ipc_lock.value_or(((caps >> 14) & 1U) != 0);  // CAP_IPC_LOCK
  const Limit rtprio = in.rtprio.value_or(get_limit(RLIMIT_RTPRIO));
  const std::string rt_text = rtprio.unlimited ? "unlimited" : std::to_string(rtprio.soft);
  if (nice_cap || rtprio.unlimited || rtprio.soft >= static_cast<std::uint64_t>(in.priority))
    add(r, "rtprio limit", CheckStatus::kOk,
        fmt::format("{}{} (loop asks for SCHED_FIFO {})", rt_text,
                    nice_cap ? ", CAP_SYS_NICE held" : "", in.priority));
  else
    add(r, "rtprio limit", CheckStatus::kFail,
        fmt::format("{} < SCHED_FIFO priority {} asked by the loop", rt_text, in.priority),
        "the dualv service sets LimitRTPRIO=99; for a shell add '<user> - rtprio 99' to "
        "/etc/security/limits.d/dualv.conf and log in again");

  const Limit memlock = in.memlock.value_or(get_limit(RLIMIT_MEMLOCK));
  if (lock_cap || memlock.unlimited)
    add(r, "memlock limit", CheckStatus::kOk,
        memlock.unlimited ? "unlimited" : fmt::format("{} bytes, CAP_IPC_LOCK held", memlock.soft));
  else
    add(r, "memlock limit", CheckStatus::kFail,
        fmt::format("{} bytes: mlockall of the whole process will fail", memlock.soft),
        "the dualv service sets LimitMEMLOCK=infinity; for a shell add '<user> - memlock "
        "unlimited' to /etc/security/limits.d/dualv.conf and log in again");

  // --- CAN interface.
  const std::string ifname = in.can_interface;
  const std::string net = sys + "/class/net/" + ifname;
  const auto type = read_trimmed(net + "/type");
  if (!safe_ifname(ifname) || !type) {
    add(r, "CAN interface " + ifname, CheckStatus::kFail, "not present",
        "connect the CAN adapter and check its driver is loaded (ip link; dmesg | grep -i can); "
        "set the interface name in the configuration if it is not " +
            ifname);
    return r;
  }
  if (*type != "280") {  // ARPHRD_CAN
    add(r, "CAN interface " + ifname, CheckStatus::kFail,
        fmt::format("exists but is not a CAN interface (link type {})", *type),
        "point the configuration at the CAN interface (ip -details link shows 'link/can')");
    return r;
  }
  const auto flags = read_trimmed(net + "/flags");
  const bool up = flags && (std::strtoul(flags->c_str(), nullptr, 16) & 0x1UL) != 0;  // IFF_UP
  const std::string details = in.ip_details.has_value()
                                  ? *in.ip_details
                                  : run_command("ip -details link show " + ifname + " 2>/dev/null");
  const IpCanDetails d = parse_ip_details(details);
  if (up)
    add(r, "CAN interface " + ifname, CheckStatus::kOk,
        fmt::format("present and up{}", d.vcan ? " (virtual CAN: vcan)" : ""));
  else
    add(r, "CAN interface " + ifname, CheckStatus::kFail, "present but down",
        fmt::format("install the dualv package's /lib/systemd/network/80-{0}.network and enable "
                    "systemd-networkd, or run: ip link set {0} up type can bitrate {1} "
                    "restart-ms 100",
                    ifname, in.can_bitrate));

  if (d.vcan) {
    add(r, "CAN bitrate", CheckStatus::kWarn, "virtual CAN has no bitrate",
        "fine for the simulator; the robot needs a real CAN interface");
  } else if (!d.bitrate) {
    add(r, "CAN bitrate", details.empty() ? CheckStatus::kWarn : CheckStatus::kFail,
        details.empty() ? "unknown (`ip -details link show` not available)" : "not configured",
        fmt::format("ip link set {} type can bitrate {} (interface down first)", ifname,
                    in.can_bitrate));
  } else if (*d.bitrate != in.can_bitrate) {
    add(r, "CAN bitrate", CheckStatus::kFail,
        fmt::format("{} bit/s, configuration says {}", *d.bitrate, in.can_bitrate),
        fmt::format("ip link set {0} down; ip link set {0} type can bitrate {1}; ip link set {0} "
                    "up (or BitRate= in 80-{0}.network)",
                    ifname, in.can_bitrate));
  } else {
    add(r, "CAN bitrate", CheckStatus::kOk, fmt::format("{} bit/s", *d.bitrate));
  }
  if (d.state) {
    const bool bad = *d.state == "BUS-OFF" || *d.state == "STOPPED";
    add(r, "CAN controller state", bad ? CheckStatus::kFail : CheckStatus::kOk, *d.state,
        bad ? fmt::format("check wiring and termination (120 ohm at both ends), then "
                          "ip link set {0} down; ip link set {0} up",
                          ifname)
            : std::string());
  }
  return r;
}

}  // namespace dualv::runtime
