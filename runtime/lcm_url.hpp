#pragma once
// Opening LCM for the CLI commands with errors that say what to do, and the URL operator input
// travels on.
#include <memory>
#include <string>

namespace lcm {
class LCM;
}

namespace dualv::runtime {

// Opens `url` (empty: the live default, channels.hpp kLiveUrl). Throws
// std::runtime_error with a hint when LCM cannot (no multicast route, bad URL).
std::unique_ptr<lcm::LCM> open_lcm(const std::string& url);

// The URL of operator input (DUALV_COMMAND, DUALV_SETPOINT), given the robot's LCM URL (the
// `--lcm` of `dualv run` and of the CLI): for udpm, the same multicast group one port up
// (udpm://239.255.76.67:7667?ttl=0 -> udpm://239.255.76.67:7668?ttl=0; no port: LCM's 7667),
// any other provider (memq://, file://) the URL itself; empty is kLiveUrl, as for open_lcm. A udpm
// socket receives every message sent to its group and port, whatever the channel: on the
// telemetry's port, `dualv run`'s command channel had to read the 1 kHz telemetry before an e-stop
// queued behind it (~1 s in the user-mode-linux guest, or dropped when LCM's receive queue was
// full). Throws std::invalid_argument naming the URL when its port is not a number in 1..65534.
std::string command_url(const std::string& robot_url);

}  // namespace dualv::runtime
