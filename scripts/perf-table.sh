#!/usr/bin/env bash
# The project's performance table, as README.md shows it: controller cycle time, simulation
# speed, in-process loop jitter, worst-case CAN bus load of every layout (`dualv bus-load`), and
# the closed-loop tracking figures of the paper program (per shape and over the whole program). Builds what it needs (release) first. Prints Markdown.
#   scripts/perf-table.sh [BUILD_DIR]     (default build/release)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build/release}
bash scripts/install-deps.sh
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$build" -j"$(nproc)" --target dualv controller_cycle_bench sim_bench model_bench \
  trajectory_bench >/dev/null
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
dualv=$build/apps/dualv

cycle=$("$build/bench/controller_cycle_bench" | awk 'f{print; exit} /median ns/{f=1}')
read -r _ c_med _ c_p999 _ <<<"$cycle"
# Two rows: /1 = AVX2 where this CPU has it, /0 = the baseline x86-64 (SSE2) path. Prints
# "<rate> <label>".
sim_rate() {
  "$build/bench/sim_bench" --benchmark_filter="BM_PlantPaperProgram/$1" --benchmark_format=csv \
    2>/dev/null | awk -F, 'NR>1 && $1 ~ /PaperProgram/ {gsub(/"/, "", $8); printf "%.0f %s\n", $NF, $8}' |
    tail -n 1
}
read -r sim_fast simd <<<"$(sim_rate 1)"
read -r sim_base _ <<<"$(sim_rate 0)"
model=$("$build/bench/model_bench" --benchmark_filter=BM_InverseDynamicsWithProjection \
  --benchmark_format=csv 2>/dev/null | awk -F, 'NR>1 {printf "%.0f", $4}')
traj=$("$build/bench/trajectory_bench" --benchmark_format=csv 2>/dev/null |
  awk -F, 'NR>1 && NR==2 {printf "%.0f", $4}')
"$dualv" run --realtime --variant retimed --no-plots --out "$tmp/rt" >"$tmp/rt.log" 2>&1 || true
late=$(awk '/lateness/ {print "median " $3 " us, p99.9 " $9 " us, max " $11 " us"}' "$tmp/rt.log")
misses=$(awk '/^loop:/ {for (i=1;i<=NF;i++) if ($i=="deadline" && $(i+1) ~ /misses/) print $(i-1)}' "$tmp/rt.log")
"$dualv" bus-load >"$tmp/bus.log"
# One row per bus layout, from `dualv bus-load`'s side-by-side table (firmware_if/bus_layout.hpp).
bus_rows=$(awk '/^Layouts for/ {match($0, /at [0-9.]+ Hz/); at = substr($0, RSTART + 3, RLENGTH - 3)}
  $1 ~ /^(per_drive|broadcast|fd)$/ && $NF ~ /^(yes|NO)$/ {
    data = $3 > 0 ? sprintf(" + %s data-phase bits", $3) : ""
    printf "| CAN bus, %s layout, worst case | %s bits/cycle%s = %s us; at %s: %s %% cyclic, %s %% with event frames; max rate %s Hz | <= 90 %% cyclic, <= 95 %% with events |\n", \
      $1, $2, data, $4, at, $5, $7, $11
  }' "$tmp/bus.log")
"$dualv" run --no-plots --out "$tmp/sim" >"$tmp/sim.log" 2>&1
track=$(grep '^retimed vs original clock (all shapes)' "$tmp/sim.log" | sed 's/^retimed vs original clock (all shapes): //')
track_program=$(grep '^retimed vs original clock (whole program)' "$tmp/sim.log" |
  sed 's/^retimed vs original clock (whole program): //')
xy=$(awk -F, '$1=="retimed" && $2=="all" {printf "%.3f mm in x, %.3f mm in y", $4, $5}' "$tmp/sim/summary.csv")
xy_program=$(awk -F, '$1=="retimed" && $2=="program" {printf "%.3f mm in x, %.3f mm in y", $4, $5}' "$tmp/sim/summary.csv")
# RMS |N tau| of the commands over the shapes: projection on (retimed) and off.
internal=$(awk -F, '$2=="all" && $1=="retimed" {on=$9} $2=="all" && $1=="retimed-no-projection" {off=$9}
  END {printf "%.2g N m with projection, %.3f N m without", on, off}' "$tmp/sim/summary.csv")

cat <<TABLE
| what | result | target |
|---|---|---|
| controller cycle (read, estimate, sample, control law, projection, safety, write), each cycle's least of 5 passes | median ${c_med} ns, p99.9 ${c_p999} ns | median < 2000 ns, p99.9 < 10000 ns |
| model: IK + Jm + Jm_dot + inverse dynamics + projection | ${model} ns | < 2000 ns |
| trajectory sample (paper program, Cartesian + joint) | ${traj} ns | < 1000 ns |
| simulation speed (paper program, 1 kHz control, 10 kHz RK4 plant, all realism knobs) | ${sim_fast}x real time with ${simd}; ${sim_base}x on the baseline x86-64 (SSE2) path | > 200x |
| in-process loop at 1 kHz, monotonic clock, 5 s | lateness ${late}; ${misses:-0} deadline misses | (measured, not assumed) |
${bus_rows}
| paper program, retimed, 1 kHz, realism knobs on | max error ${xy} over the shapes; ${xy_program} over the whole program | < 0.6 mm x, < 1.0 mm y |
| retimed vs original clock, the shapes | ${track} | retimed lower on both |
| retimed vs original clock, the whole program (moves, dwells, ringing after each shape) | ${track_program} | retimed lower on both |
| internal (antagonistic) torque, RMS over the shapes | ${internal} | ~0 with projection |

Machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(uname -sr), load average $(cut -d' ' -f1-3 /proc/loadavg).
TABLE
