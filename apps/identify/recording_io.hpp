#pragma once
// Recordings for `dualv identify` (issue 16): from a closed-loop run in memory, from the CSV
// time series `dualv run` writes (<out>/<variant>.csv) or from an LCM log of robot_state_t
// (<out>/telemetry.lcmlog, or one recorded with lcm-logger). Set-up code.
#include <string>

#include "apps/experiment/closed_loop.hpp"
#include "apps/experiment/robot_config.hpp"
#include "control/identification/identify.hpp"

namespace dualv::apps {

// Every row of a run: measured pose and torque sent.
identification::Recording recording_from_run(const RunResult& run, double period);

// Reads a CSV of `dualv run` (columns t, x, y, theta, tau1..tauN) or an LCM log (.lcmlog; the
// longest run in it). Throws std::runtime_error naming the file and what is missing.
identification::Recording read_recording(const std::string& path);

// The drive chain's latency from the torque sent to the torque acting, as the `plant:` section
// describes it: transport delay cycles + half a cycle (the drive holds a command for a cycle)
// + the current loop's time constant [s].
double drive_latency(const RobotConfig& config);

}  // namespace dualv::apps
