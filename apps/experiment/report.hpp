#pragma once
// What a closed-loop run leaves behind: a summary table on the terminal, one CSV time
// series per variant, and PNG figures in the spirit of the paper's figures 2-4, 7 and 8
// (drawn by scripts/plot_run.py with Debian's matplotlib).
#include <cstdint>
#include <string>
#include <vector>

#include "apps/experiment/closed_loop.hpp"
#include "drivers/canopen_actuator_set.hpp"

namespace dualv::apps {

// The per-shape table of every run, then the comparison the paper makes.
std::string summary_table(const std::vector<RunResult>& runs);

// Writes <dir>/<variant>.csv (one row per cycle) and <dir>/summary.csv. Throws
// std::runtime_error naming the file when it cannot be written.
void write_csv(const std::string& dir, const std::vector<RunResult>& runs);

// What the CANopen master counted on the bus (SYNCs, send errors, bus-off, foreign and
// malformed frames; per drive TPDOs, misses, EMCYs...): the `bus:` report of `dualv run --can`
// and `dualv selftest --can`, which the HIL tests read. `syncs_before` >= 0: the SYNCs sent
// before the program (priming), shown next to the total.
std::string bus_report(const drivers::CanopenActuatorSet& set, std::int64_t syncs_before = -1);
void write_run_csv(const std::string& file, const RunResult& run);

// Runs the plotting script on <dir>; returns "" on success, else why no plots were drawn.
std::string draw_plots(const std::string& dir);

// The folder scripts are installed in (source tree for developer builds).
std::string scripts_dir();

}  // namespace dualv::apps
