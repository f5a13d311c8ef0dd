#pragma once
// Opening LCM for the CLI commands with errors that say what to do.
#include <memory>
#include <string>

namespace lcm {
class LCM;
}

namespace dualv::runtime {

// Opens `url` (empty: the live default, channels.hpp kLiveUrl). Throws
// std::runtime_error with a hint when LCM cannot (no multicast route, bad URL).
std::unique_ptr<lcm::LCM> open_lcm(const std::string& url);

}  // namespace dualv::runtime
