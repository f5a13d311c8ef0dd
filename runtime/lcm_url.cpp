#include "runtime/lcm_url.hpp"

#include <fmt/format.h>

#include <charconv>
#include <lcm/lcm-cpp.hpp>
#include <stdexcept>

#include "runtime/channels.hpp"

namespace dualv::runtime {

std::unique_ptr<lcm::LCM> open_lcm(const std::string& url) {
  const std::string u = url.empty() ? std::string(kLiveUrl) : url;
  auto l = std::make_unique<lcm::LCM>(u);
  if (!l->good()) {
    std::string hint = "check the URL (udpm://239.255.76.67:7667?ttl=0, file:///path.lcmlog)";
    if (u.rfind("udpm://", 0) == 0)
      hint =
          "UDP multicast needs a route for 224.0.0.0/4 (ip route add 224.0.0.0/4 dev lo for "
          "this machine only; dev <nic> with ttl=1 between machines) and the interface "
          "multicast-enabled (ip link set lo multicast on)";
    throw std::runtime_error(fmt::format("cannot open LCM URL '{}': {}", u, hint));
  }
  return l;
}

std::string command_url(const std::string& robot_url) {
  // Empty is the live default, as for open_lcm: its commands must not stay on the telemetry's port.
  const std::string lcm_url = robot_url.empty() ? std::string(kLiveUrl) : robot_url;
  const std::string scheme = "udpm://";
  if (lcm_url.rfind(scheme, 0) != 0) return lcm_url;
  // udpm://[group[:port]][?options]: LCM's own defaults for an empty group or port.
  const std::size_t options = lcm_url.find('?', scheme.size());
  const std::string network = lcm_url.substr(
      scheme.size(), options == std::string::npos ? std::string::npos : options - scheme.size());
  const std::string rest = options == std::string::npos ? "" : lcm_url.substr(options);
  const std::size_t colon = network.find(':');
  const std::string group =
      network.empty() ? "239.255.76.67" : network.substr(0, colon);  // LCM's default group
  int port = 7667;                                                   // LCM's default port
  if (colon != std::string::npos) {
    const std::string digits = network.substr(colon + 1);
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), port);
    if (digits.empty() || ec != std::errc() || end != digits.data() + digits.size() || port < 1 ||
        port > 65534)
      throw std::invalid_argument(
          fmt::format("LCM URL '{}': the port must be a number in 1..65534 (operator commands "
                      "use the next one up)",
                      lcm_url));
  }
  return fmt::format("{}{}:{}{}", scheme, group, port + 1, rest);
}

}  // namespace dualv::runtime
