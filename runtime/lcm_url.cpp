#include "runtime/lcm_url.hpp"

#include <fmt/format.h>

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

}  // namespace dualv::runtime
