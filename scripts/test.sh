#!/usr/bin/env bash
# The whole test suite, as CI runs it: install dependencies, build with warnings as
# errors, run every test (unit, property, and the vcan hardware-in-the-loop tests in a
# user-mode-linux guest: on its real clock, then the closed loops again on a virtual clock in a
# time-travel kernel built from Debian's linux-source-6.1), build and install the Debian package and run the installed binary,
# then rebuild with AddressSanitizer + UBSan and run the tests again, rebuild the threaded
# tests with ThreadSanitizer and run them, and run every libFuzzer target (fuzz/) for a
# bounded time on its seed corpus (scripts/fuzz.sh; a finding fails the suite).
# The layer check (scripts/check-layers.sh) and the format check run first: an upward include
# or an unformatted source file fails the suite.
# Usage: scripts/test.sh            (everything)
#        DUALV_SKIP_ASAN=1 scripts/test.sh   (skip the ASan + UBSan pass; fuzz then builds build/fuzz)
#        DUALV_SKIP_TSAN=1 scripts/test.sh   (skip the ThreadSanitizer pass)
#        DUALV_SKIP_FUZZ=1 scripts/test.sh   (skip the fuzzing)
#        DUALV_FUZZ_SECONDS=S scripts/test.sh   (seconds per fuzz target, default 20)
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)

# Each phase prints its start; at the end (or at a failure) a table of what each took, so a
# slow CI run shows where its time went (issue 14: the suite stays under 45 min on 2 cores).
suite_start=$SECONDS
phase_names=()
phase_secs=()
phase_start=$SECONDS
phase() {
  phase_close
  phase_names+=("$1")
  phase_start=$SECONDS
  echo "== $1 == (at $(( (SECONDS - suite_start) / 60 )) min)"
}
phase_close() {
  [ ${#phase_names[@]} -gt ${#phase_secs[@]} ] && phase_secs+=($((SECONDS - phase_start)))
  return 0
}
phase_summary() {
  local rc=$?
  phase_close
  echo "== time per phase =="
  for i in "${!phase_names[@]}"; do
    printf '%6d s  %s\n' "${phase_secs[$i]}" "${phase_names[$i]}"
  done
  printf '%6d s  total (exit %d)\n' $((SECONDS - suite_start)) "$rc"
}
trap phase_summary EXIT

phase "dependencies (scripts/install-deps.sh)"
bash scripts/install-deps.sh

# The layers (docs/architecture.md "Layers"): no include may go up; seconds, so first.
phase "layers (scripts/check-layers.sh)"
bash scripts/check-layers.sh

# The code is clang-formatted (.clang-format): seconds, so first too. The files git tracks, or
# outside a clone every source file but the build folders'.
phase "format (clang-format --dry-run --Werror)"
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  git ls-files -z '*.cpp' '*.hpp' '*.h' | xargs -0 clang-format --dry-run --Werror
else
  find . -path ./build -prune -o \( -name '*.cpp' -o -name '*.hpp' -o -name '*.h' \) -print0 |
    xargs -0 clang-format --dry-run --Werror
fi

# ccache (scripts/install-deps.sh): the package build (scripts/package-test.sh, build/package)
# compiles with the release build's flags, so all but the objects that bake in its install
# paths come from the cache. Paths are hashed relative to the checkout, the working directory
# not at all: build/release and build/package then share entries.
launcher=()
if command -v ccache >/dev/null; then
  export CCACHE_BASEDIR=$PWD CCACHE_NOHASHDIR=1
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi

phase "release build (-Werror)"
cmake -S . -B build/release -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDUALV_WERROR=ON "${launcher[@]}" >/dev/null
cmake --build build/release -j"$jobs"
phase "tests (release)"
ctest --test-dir build/release --output-on-failure -j"$jobs" --timeout 900 -LE hil
# HIL tests boot a user-mode-linux guest whose timing is coarse (ms-scale stalls on a shared
# machine): one at a time, and a case that fails is run once more (it must then pass).
phase "hardware-in-the-loop tests on the guest's real clock (vcan in user-mode-linux)"
# tests/hil/KNOWN_FAILING lists HIL tests that fail since the always-on loop (issue 12) and
# are being fixed: they run and report below, but do not stop this script. Every other HIL
# test gates as before. The list must shrink to nothing; see the file for each reason.
# (awk, not grep: an empty list is no error, where grep's exit 1 would end this script)
known=$(awk '!/^#/ && NF {print $1}' tests/hil/KNOWN_FAILING | paste -sd'|' -)
if [[ -n $known ]]; then
  ctest --test-dir build/release --output-on-failure --timeout 900 -L hil -LE hil_virtual_clock \
    -E "^(${known})\$" --repeat until-pass:2
  phase "known-failing HIL tests (reported, not gating: tests/hil/KNOWN_FAILING)"
  ctest --test-dir build/release --output-on-failure --timeout 900 -L hil -R "^(${known})\$" ||
    echo "KNOWN FAILING (not gating, tests/hil/KNOWN_FAILING): ${known}"
else
  ctest --test-dir build/release --output-on-failure --timeout 900 -L hil -LE hil_virtual_clock \
    --repeat until-pass:2
fi
# The same closed loops on the virtual clock (tests/hil/README.md "Guest clocks: real and
# virtual"), in a time-travel guest kernel built once from Debian's linux-source-6.1 and kept in
# build/uml-kernel while its inputs hold. There the guest keeps every deadline: nothing is
# excused as guest timing and a failure is not run again.
phase "time-travel UML kernel (tests/hil/uml_kernel/build.sh)"
bash tests/hil/uml_kernel/build.sh build/uml-kernel
phase "hardware-in-the-loop tests on the virtual clock"
DUALV_HIL_REQUIRE_VIRTUAL=1 ctest --test-dir build/release --output-on-failure --timeout 900 \
  -L hil_virtual_clock

phase "package: build the .deb, install it, run the installed dualv"
bash scripts/package-test.sh --jobs "$jobs"

# One sanitizer build serves the ASan + UBSan pass and the fuzzing: clang, every target
# instrumented for ASan + UBSan and libFuzzer's coverage (-DDUALV_FUZZ=ON), at -O1. The tests
# run in it, then the fuzz targets are linked there (scripts/fuzz.sh --build): one compile of
# the libraries, not two (issue 14: the suite stays under 45 min on 2 cores). The release
# build above was GCC: the code is compiled by both.
sanitize_build=""
if [ "${DUALV_SKIP_ASAN:-0}" != 1 ]; then
  phase "sanitizer build (clang: ASan + UBSan, libFuzzer coverage)"
  # Warnings are enforced by the release build above.
  sanitize_build=build/sanitize
  CC=clang CXX=clang++ cmake -S . -B "$sanitize_build" -DCMAKE_BUILD_TYPE=Debug \
    -DCMAKE_CXX_FLAGS_DEBUG="-g -O1" -DDUALV_FUZZ=ON -DDUALV_WERROR=OFF \
    -DDUALV_BUILD_BENCH=OFF >/dev/null
  cmake --build "$sanitize_build" -j"$jobs"
  phase "tests (ASan + UBSan)"
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir "$sanitize_build" --output-on-failure -j"$jobs" --timeout 1800
fi

if [ "${DUALV_SKIP_TSAN:-0}" != 1 ]; then
  phase "ThreadSanitizer build (the threaded tests)"
  # -O1, as ThreadSanitizer's documentation suggests (and a quicker compile).
  cmake -S . -B build/tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g -DNDEBUG" -DDUALV_TSAN=ON -DDUALV_WERROR=OFF \
    -DDUALV_BUILD_BENCH=OFF >/dev/null
  # The tests that run threads: the command channel, telemetry publisher and service
  # notifier (runtime_tests), the SPSC queue (common_tests), the periodic executive
  # (loop_tests), the real-time loop on its own thread with a supervisor (executor_tests), the e-stop latch, the fault log and stop requests from another thread
  # (safety_tests), a streamed closed loop with its telemetry (apps_stream_tests).
  cmake --build build/tsan -j"$jobs" --target runtime_tests common_tests loop_tests safety_tests \
    apps_stream_tests executor_tests
  phase "tests (ThreadSanitizer)"
  export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1"
  build/tsan/tests/runtime/runtime_tests --gtest_brief=1
  build/tsan/tests/common/common_tests --gtest_brief=1 --gtest_filter='SpscQueue.*'
  build/tsan/tests/control/loop/loop_tests --gtest_brief=1
  build/tsan/tests/control/loop/executor_tests --gtest_brief=1 --gtest_filter='*OnItsOwnThread*'
  build/tsan/tests/safety/safety_tests --gtest_brief=1 --gtest_filter='EstopLatch.*:FaultLog.*:SafetyFilter.*'
  build/tsan/tests/apps/apps_stream_tests --gtest_brief=1
  unset TSAN_OPTIONS
fi

if [ "${DUALV_SKIP_FUZZ:-0}" != 1 ]; then
  phase "fuzzing (libFuzzer + ASan + UBSan, ${DUALV_FUZZ_SECONDS:-20} s per target)"
  bash scripts/fuzz.sh --time "${DUALV_FUZZ_SECONDS:-20}" --jobs "$jobs" \
    ${sanitize_build:+--build "$sanitize_build"}
fi
