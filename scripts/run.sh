#!/usr/bin/env bash
# The main job: builds dualv if needed and runs it. With no arguments it runs the
# paper's experiment in closed loop against the in-process simulation (no hardware,
# no network, no root). Any arguments are passed to `dualv` instead, e.g.
#   scripts/run.sh model --pose 0.01 0.26 0.05
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build/release -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build/release -j"$(nproc)" --target dualv
if [ $# -eq 0 ]; then
  if build/release/apps/dualv run --help >/dev/null 2>&1; then
    set -- run
  else
    set -- model
  fi
fi
exec build/release/apps/dualv "$@"
