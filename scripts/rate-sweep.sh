#!/usr/bin/env bash
# The rate experiment of issue 15: the paper program in the in-process simulation at 0.5, 1,
# 1.5, 2, 2.5, 5 and 10 kHz with the shipped gains and with gains scaled with the rate
# (scripts/rate_sweep.py states the rule). Builds `dualv` (release) first; prints a Markdown
# table and writes rate_sweep.csv and rate_sweep.png.
#   scripts/rate-sweep.sh [OUT_DIR] [BUILD_DIR]   (default out/rate-sweep, build/release)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-out/rate-sweep}
build=${2:-build/release}
bash scripts/install-deps.sh
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$build" -j"$(nproc)" --target dualv >/dev/null
# Debian's python3 (matplotlib, numpy, yaml); a python3 earlier on PATH may not see them.
exec /usr/bin/python3 scripts/rate_sweep.py --dualv "$build/apps/dualv" --out "$out"
