#!/usr/bin/env bash
# Builds the dualv .deb, installs it on this machine with dpkg -i, verifies the installed
# systemd unit (systemd-analyze verify, when installed), and runs the installed binary:
# `dualv --version`, then (when the binary has a `run` command) a short simulated
# `dualv run` that must find its configuration in /etc/dualv, and `dualv identify`, which must
# find identify.yaml and paper.yaml there. Removes the package again at the end unless --keep.
#
#   scripts/package-test.sh [--keep] [--build DIR] [--jobs N]
#
# Needs root (dpkg -i) or sudo. CI runs it as root.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${DUALV_PACKAGE_BUILD:-$root/build/package}
jobs=${JOBS:-2}
keep=0
while [[ $# -gt 0 ]]; do
  case $1 in
    --keep) keep=1; shift ;;
    --build) build=${2:?}; shift 2 ;;
    --jobs) jobs=${2:?}; shift 2 ;;
    *) echo "package-test: unknown argument $1" >&2; exit 2 ;;
  esac
done

SUDO=""
[[ $(id -u) -eq 0 ]] || SUDO="sudo"
say() { echo "package-test: $*"; }
fail() { echo "package-test: FAIL: $*" >&2; exit 1; }

# Runs a step quietly; on failure shows the end of its output.
step() {
  local what=$1
  shift
  say "$what"
  mkdir -p "$build"
  if ! "$@" >"$build/package-test-step.log" 2>&1; then
    tail -n 40 "$build/package-test-step.log" >&2
    fail "$what"
  fi
}

# The flags of the tested release build (scripts/test.sh: RelWithDebInfo, -Werror): what is
# installed is what the tests ran, stripped by cpack (packaging/CMakeLists.txt). With ccache,
# every object but the few that bake in /etc/dualv comes from the release build's cache
# (build/release and build/package are at the same depth: the same relative paths).
launcher=()
command -v ccache >/dev/null &&
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
step "configuring $build for the target (/usr, /etc/dualv)" \
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDUALV_WERROR=ON \
  -DCMAKE_INSTALL_PREFIX=/usr -DDUALV_CONFIG_DIR=/etc/dualv -DDUALV_BUILD_TESTS=OFF \
  -DDUALV_BUILD_BENCH=OFF "${launcher[@]}"
step "building" cmake --build "$build" -j "$jobs"
rm -f "$build"/dualv_*.deb
step "packaging (cpack -G DEB)" bash -c "cd '$build' && cpack -G DEB"
deb=$(ls -t "$build"/dualv_*.deb 2>/dev/null | head -n 1)
[[ -n "$deb" ]] || fail "cpack produced no .deb in $build"
say "built $(basename "$deb")"

contents=$(dpkg-deb --contents "$deb")
for f in ./usr/bin/dualv ./etc/dualv/dualv.yaml ./etc/dualv/identify.yaml ./etc/default/dualv \
  ./usr/share/dualv/plot_run.py ./usr/share/dualv/plot_identification.py \
  ./usr/lib/systemd/system/dualv.service ./usr/lib/systemd/network/80-can0.network \
  ./usr/share/doc/dualv/DEPLOYMENT.md ./usr/share/dualv/eds/dualv-emulated-drive.eds; do
  grep -q " $f\$" <<<"$contents" || fail "$f missing from the package"
done
# Captured first: with pipefail, grep -q closing the pipe early would fail the pipeline.
info=$(dpkg-deb --info "$deb")
grep -q "conffiles" <<<"$info" || fail "no conffiles in the package"

say "installing with dpkg -i"
$SUDO dpkg -i "$deb" >/dev/null
cleanup() {
  if [[ $keep -eq 0 ]]; then
    say "removing the package (--keep keeps it; purged with its conffiles)"
    $SUDO dpkg --purge dualv >/dev/null || true
  fi
}
trap cleanup EXIT

# The installed unit as systemd reads it (offline: needs no running systemd, so it works
# in a CI container). verify exits 0 on values it ignores (a bad WatchdogSec=, a typo'd
# key), naming the file and line: those fail the test too.
unit=/usr/lib/systemd/system/dualv.service
if command -v systemd-analyze >/dev/null 2>&1; then
  say "systemd-analyze verify $unit"
  verify_rc=0
  verify_out=$(systemd-analyze verify "$unit" 2>&1) || verify_rc=$?
  if [[ $verify_rc -ne 0 ]] || grep -q "dualv.service:" <<<"$verify_out"; then
    echo "$verify_out" >&2
    fail "systemd-analyze verify $unit (exit $verify_rc)"
  fi
  grep -qx "Type=notify" "$unit" || fail "$unit is not Type=notify"
  grep -q "^WatchdogSec=" "$unit" || fail "$unit has no WatchdogSec="
else
  say "systemd-analyze not installed (package systemd): skipped verifying $unit"
fi

dualv=/usr/bin/dualv
version=$("$dualv" --version)
say "installed: $version"
[[ "$version" == dualv* ]] || fail "unexpected --version output: $version"

# The shipped EDS against the installed configuration (/etc/dualv/dualv.yaml).
eds=/usr/share/dualv/eds/dualv-emulated-drive.eds
(cd / && env -u DUALV_CONFIG "$dualv" eds-check "$eds" >/dev/null) ||
  fail "dualv eds-check $eds with /etc/dualv/dualv.yaml failed"
say "dualv eds-check $eds: ok"

# The installed binary must look for its configuration in /etc/dualv, never in
# the source tree it was built from.
if "$dualv" run --help >/dev/null 2>&1; then
  run_help=$("$dualv" run --help 2>&1 || true)
  grep -q "/etc/dualv" <<<"$run_help" || say "note: run --help does not name /etc/dualv"
  work=$(mktemp -d)
  say "short simulated run from the installed binary in $work"
  # Hide the source tree's config: a binary falling back to it must fail here.
  if ! (cd "$work" && env -u DUALV_CONFIG timeout 900 "$dualv" run --no-plots --out "$work/out" \
    ${DUALV_PACKAGE_RUN_ARGS:-} >"$work/run.log" 2>&1); then
    tail -n 30 "$work/run.log" >&2
    fail "dualv run from the installed package failed"
  fi
  tail -n 5 "$work/run.log"
  rm -rf "$work"
else
  say "dualv run not in this build yet: skipped the simulated run"
fi
# `dualv identify` finds its settings and the validation program in /etc/dualv (issue 16):
# the excitation, the estimation and the report from the installed files alone.
if "$dualv" identify --help >/dev/null 2>&1; then
  grep -q "/etc/dualv/identify.yaml" <<<"$("$dualv" identify --help 2>&1)" ||
    fail "identify --help does not name /etc/dualv/identify.yaml"
  work=$(mktemp -d)
  say "dualv identify from the installed binary in $work"
  if ! (cd "$work" && env -u DUALV_CONFIG timeout 900 "$dualv" identify --out "$work/out" \
    >"$work/identify.log" 2>&1); then
    tail -n 30 "$work/identify.log" >&2
    fail "dualv identify from the installed package failed"
  fi
  for f in report.txt identified.yaml validation_torques.csv tracking.txt; do
    [[ -s "$work/out/$f" ]] || fail "dualv identify wrote no $f"
  done
  grep -q "/etc/dualv/paper.yaml" "$work/identify.log" ||
    fail "dualv identify did not validate on /etc/dualv/paper.yaml"
  tail -n 3 "$work/identify.log"
  rm -rf "$work"
fi
if "$dualv" check-target --help >/dev/null 2>&1; then
  # Exit code 1 is expected on a build machine (no PREEMPT_RT, no can0).
  "$dualv" check-target --config /etc/dualv/dualv.yaml || true
fi
say "OK"
