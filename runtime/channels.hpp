#pragma once
// LCM channel names, one definition for publisher, CLI and tests.
namespace dualv::runtime {

inline constexpr const char* kStateChannel = "DUALV_STATE";           // robot_state_t
inline constexpr const char* kFaultChannel = "DUALV_FAULT";           // fault_event_t
inline constexpr const char* kLoopStatsChannel = "DUALV_LOOP_STATS";  // loop_stats_t
inline constexpr const char* kCommandChannel = "DUALV_COMMAND";       // command_t
inline constexpr const char* kSetpointChannel = "DUALV_SETPOINT";     // setpoint_t (streaming)

// Multicast confined to the host (ttl=0): the URL `dualv run --lcm` and the
// CLI use for live data. LCM's own default also uses this group and port.
inline constexpr const char* kLiveUrl = "udpm://239.255.76.67:7667?ttl=0";

}  // namespace dualv::runtime
