#!/usr/bin/env bash
# The libFuzzer targets (fuzz/): builds them with Debian's clang in build/fuzz (libFuzzer +
# AddressSanitizer + UndefinedBehaviorSanitizer) and runs each on its seed corpus
# fuzz/corpus/<target>/. Prints, per target, the executions, the time and the findings, and
# exits non-zero when any target found a crash, a leak, undefined behaviour, a timeout or an
# out-of-memory; the input that did it is kept in build/fuzz/findings/<target>/ (reproduce:
# build/fuzz/fuzz/<target>_fuzz FILE).
#
# Usage: scripts/fuzz.sh [--time SECONDS] [--runs N] [--jobs N] [TARGET...]
#   --time S   run each target for S seconds (default 20: the bounded run scripts/test.sh does)
#   --runs N   a campaign: run each target for N executions (--runs 10000000); with --time
#              too, whichever comes first (a chunk of a long campaign: --time 2400, repeated).
#              A campaign resumes from fuzz/campaign/<target>/ and adds to it and to
#              fuzz/campaign/ledger.tsv (below)
#   --keep-going  do not stop a target at its first finding (libFuzzer -fork=1
#              -ignore_crashes=1): a campaign goes on past a known, not yet fixed finding
#   --jobs N   compile with N jobs and run N targets at a time (default: nproc)
#   --workers N  run each target as N libFuzzer processes sharing its corpus (-jobs=N
#              -workers=N), --runs split among them: a campaign of one slow target on N cores
#   --build DIR  a build folder configured with clang and -DDUALV_FUZZ=ON already (scripts/test.sh's
#              build/sanitize, whose tests ran under the same ASan + UBSan): only the targets are
#              built there (default: build/fuzz, configured here)
#   TARGET     some targets only (default: all), e.g. firmware_if_decoders sdo_client
# New inputs that add coverage go to build/fuzz/corpus/<target>/ (kept between runs); fuzz/corpus/
# (the seeds) is only read.
# A campaign outlives the machine it ran on: it also reads fuzz/campaign/<target>/, and when it
# ends without a finding (also when stopped early with SIGINT: libFuzzer's exit 72 after its
# final stats) it merges what it found into that folder (libFuzzer -merge=1: the fewest inputs
# with the same features, beyond what the seeds have) and appends a line to
# fuzz/campaign/ledger.tsv (date, commit, target, executions, seconds, coverage, findings, how
# it ended), then prints each target's executions on the ledger. Commit both: the next
# campaign, on any machine, resumes there. A run with a finding adds nothing to either.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD

ALL_TARGETS=(firmware_if_decoders sdo_client command_verifier robot_config program bus_attack eds)
time_s=""
runs=""
keep_going=0
workers=1
jobs=$(nproc)
targets=()
build=""
while [ $# -gt 0 ]; do
  case "$1" in
    --time) time_s="$2"; shift 2 ;;
    --runs) runs="$2"; shift 2 ;;
    --jobs) jobs="$2"; shift 2 ;;
    --build) build="$2"; shift 2 ;;
    --keep-going) keep_going=1; shift ;;
    --workers) workers="$2"; shift 2 ;;
    -h|--help) sed -n '2,/^[^#]/{/^#/p}' "$0"; exit 0 ;;
    -*) echo "fuzz.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) targets+=("$1"); shift ;;
  esac
done
[ ${#targets[@]} -gt 0 ] || targets=("${ALL_TARGETS[@]}")
[ -n "$runs" ] || [ -n "$time_s" ] || time_s=20
[[ $workers =~ ^[1-9][0-9]*$ ]] || { echo "fuzz.sh: --workers $workers: a positive count" >&2; exit 2; }
if [ "$workers" -gt 1 ] && [ "$keep_going" = 1 ]; then
  echo "fuzz.sh: --workers and --keep-going do not go together (libFuzzer -jobs vs -fork)" >&2
  exit 2
fi
for t in "${targets[@]}"; do
  [ -d "fuzz/corpus/$t" ] || { echo "fuzz.sh: no target '$t' (known: ${ALL_TARGETS[*]})" >&2; exit 2; }
done

bash scripts/install-deps.sh
if [ -z "$build" ]; then
  build=build/fuzz
  launcher=()
  command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
  CC=clang CXX=clang++ cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDUALV_FUZZ=ON \
    -DDUALV_BUILD_TESTS=OFF -DDUALV_BUILD_BENCH=OFF "${launcher[@]}" >/dev/null
elif ! grep -q '^DUALV_FUZZ:BOOL=ON' "$build/CMakeCache.txt" 2>/dev/null; then
  echo "fuzz.sh: $build is not a build configured with -DDUALV_FUZZ=ON (clang)" >&2
  exit 2
fi
cmake --build "$build" -j"$jobs" --target "${targets[@]/%/_fuzz}"
build=$(realpath "$build")  # absolute: with --workers the fuzzers run in a folder of their own

# Per-target options: the largest input (the configuration seed is ~11 kB, the EDS seeds ~21
# kB: cut to 512 bytes, only an EDS's header was fuzzed, 1288 edges in a minute against 1492 in
# whole files) and the time one input may take before libFuzzer calls it a hang (generous: a
# loaded 2-core machine is slow; a real hang runs forever).
declare -A MAX_LEN=([robot_config]=16384 [program]=4096 [bus_attack]=2048 [command_verifier]=2048
  [eds]=32768)
campaign=$root/fuzz/campaign
ledger=$campaign/ledger.tsv
# A campaign's AddressSanitizer records no allocation stacks (malloc_context_size=0): it keeps
# every distinct stack it records for good (its stack depot), and yaml-cpp's recursive parser
# makes a new one for each nesting depth the fuzzer tries. robot_config's workers grew by ~2 MB
# per 1000 inputs, 0.7 to 1.4 GB in 20 min, towards the 2 GB limit (an out-of-memory "finding"
# that would be the sanitizer's own); without the stacks they stay at 0.5 GB, and run ~10 %
# faster. Every check is the same; only a report's "allocated by"/"freed by" stacks are
# missing: rerun the kept input for them (build/fuzz/fuzz/TARGET_fuzz FILE, printed below).
asan_options=detect_leaks=1:abort_on_error=1
[ -z "$runs" ] || asan_options+=:malloc_context_size=0
fuzz_env() {
  ASAN_OPTIONS=$asan_options UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 "$@"
}
# save_campaign TARGET WORK EXECS SECS COV ENDED: merges WORK and fuzz/campaign/TARGET into the
# fewest inputs that keep their features beyond the seeds' (the seeds go in first, so what they
# cover is had already, and come out after), replaces fuzz/campaign/TARGET with them and appends
# the run to the ledger.
save_campaign() {
  local t=$1 work=$2 execs=$3 secs=$4 cov=$5 ended=$6 dest="$campaign/$1" tmp f from=()
  tmp=$(mktemp -d "$build/merge.XXXXXX")
  cp "$root/fuzz/corpus/$t"/* "$tmp/"
  from=("$work")
  [ ! -d "$dest" ] || from+=("$dest")
  if ! fuzz_env "$build/fuzz/${t}_fuzz" -merge=1 -timeout=120 -rss_limit_mb=2048 \
      -max_len="${MAX_LEN[$t]:-512}" "$tmp" "${from[@]}" >"$build/logs/$t.merge.log" 2>&1; then
    rm -rf "$tmp"
    return 1
  fi
  for f in "$root/fuzz/corpus/$t"/*; do rm -f "$tmp/$(basename "$f")"; done
  rm -rf "$dest"
  mkdir -p "$campaign"
  mv "$tmp" "$dest"
  chmod 755 "$dest"
  [ -f "$ledger" ] ||
    printf 'date\tcommit\ttarget\texecutions\tseconds\tcoverage\tfindings\tended\n' >"$ledger"
  # One line at a time (targets run side by side): short appends, each a single write.
  printf '%s\t%s\t%s\t%s\t%s\t%s\t0\t%s\n' "$(date -u +%F)" \
    "$(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo '?')" "$t" "$execs" "$secs" "$cov" "$ended" \
    >>"$ledger"
}
# fuzz_one TARGET: runs it; its summary line and verdict go to $build/logs/TARGET.{summary,failed}
# (the targets run side by side, one per job: each libFuzzer process is single-threaded).
fuzz_one() {
  local t=$1 work findings log limit opts start status secs execs cov n slow note i
  work="$build/corpus/$t"
  findings="$build/findings/$t"
  log="$build/logs/$t.log"
  rm -rf "$findings"  # this run's findings only
  mkdir -p "$work" "$findings" "$(dirname "$log")"
  limit=()
  [ -n "$runs" ] && limit+=(-runs="$(( (runs + workers - 1) / workers ))")
  [ -n "$time_s" ] && limit+=(-max_total_time="$time_s")
  [ "$keep_going" = 1 ] && limit+=(-fork=1 -ignore_crashes=1)
  # -purge_allocator_interval=30: libFuzzer hands every free page back to the kernel each
  # second (its default) once RSS passes half of -rss_limit_mb, as a long campaign's does (~1
  # GB); on this VM the madvise and its TLB shootdowns took 22 % of a `program` worker and the
  # pages' refaults more (perf): 470 executions/s per worker, 1100-1370/s without the purge. Not
  # purging at all lets RSS climb (~30 MB/min, towards the limit); every 30 s keeps it bounded
  # at a thirtieth of the cost. The limits are unchanged: RSS and malloc 2 GB, ASan's quarantine.
  opts=(-timeout=120 -rss_limit_mb=2048 -purge_allocator_interval=30 -print_final_stats=1 -artifact_prefix="$findings/"
        -max_len="${MAX_LEN[$t]:-512}")
  echo "== fuzz $t (${runs:+$runs runs }${time_s:+$time_s s}) =="
  start=$(date +%s)
  status=0
  # With --workers N, libFuzzer's N processes write fuzz-I.log in the folder it runs in (and
  # the main process copies each into its own log as it ends: counted once, from fuzz-I.log).
  local wdir="$build/logs/$t.workers" wlogs=("$log")
  rm -rf "$wdir"
  if [ "$workers" -gt 1 ]; then
    mkdir -p "$wdir"
    limit+=(-jobs="$workers" -workers="$workers")
    wlogs=()
    for ((i = 0; i < workers; ++i)); do wlogs+=("$wdir/fuzz-$i.log"); done
  fi
  local dirs=("$work" "$root/fuzz/corpus/$t")
  [ -z "$runs" ] || [ ! -d "$campaign/$t" ] || dirs+=("$campaign/$t")
  (
    [ "$workers" -eq 1 ] || cd "$wdir"
    fuzz_env "$build/fuzz/${t}_fuzz" "${limit[@]}" "${opts[@]}" "${dirs[@]}"
  ) >"$log" 2>&1 || status=$?
  secs=$(( $(date +%s) - start ))
  # The sum of every worker's executions; the coverage of the one that saw most.
  execs=$(cat "${wlogs[@]}" 2>/dev/null | sed -n 's/^stat::number_of_executed_units: *//p' |
    awk '{ n += $1; any = 1 } END { if (any) print n }' || true)
  cov=$(for l in "${wlogs[@]}"; do grep -o 'cov: [0-9]*' "$l" 2>/dev/null | tail -1; done |
    cut -d' ' -f2 | sort -n | tail -1 || true)
  # (fork mode prints no final stats: its last progress line "#N: cov: ...")
  [ -n "$execs" ] || execs=$(grep -oE '^#[0-9]+' "$log" | tail -1 | tr -d '#' || true)
  # A slow unit (libFuzzer's slow-unit-*: one input took over -report_slow_units, 10 s, of wall
  # time) is kept and reported but is not a finding: on a loaded machine (a campaign under
  # `chrt --idle`, beside a build) wall time is the machine's, not the input's. A real hang is
  # -timeout's (a finding).
  n=$(find "$findings" -type f ! -name 'slow-unit-*' | wc -l)
  slow=$(find "$findings" -type f -name 'slow-unit-*' | wc -l)
  note=""
  [ "$slow" -eq 0 ] || note="  (slow units, over 10 s of wall time each: $slow, kept in $findings)"
  # SIGINT: libFuzzer prints its final stats and exits 72; what ran until then had no finding.
  # Send it to the fuzzer processes, not to this script (`pkill -INT -f <target>_fuzz`): with
  # --workers each worker exits 72 and the process that started them (through std::system,
  # which ignores SIGINT meanwhile) then exits 1.
  local ended=completed interrupted=0
  if [ "$n" -eq 0 ] && ! grep -q 'ERROR: libFuzzer\|runtime error' "${wlogs[@]}" "$log" 2>/dev/null; then
    if [ "$workers" -eq 1 ]; then
      [ "$status" -ne 72 ] || interrupted=1
    elif [ "$status" -eq 1 ]; then
      interrupted=1
      for i in "${wlogs[@]}"; do grep -q 'libFuzzer: run interrupted' "$i" || interrupted=0; done
    fi
  fi
  if [ "$interrupted" = 1 ]; then
    ended=interrupted
    status=0
    note+="  (stopped early with SIGINT)"
  fi
  # A campaign in chunks (--runs with --time: a chunk's corpus and ledger line are on disk
  # before the next starts, so a machine that goes away mid-campaign loses one chunk at most)
  # ends on its time before its runs.
  if [ "$ended" = completed ] && [ -n "$time_s" ] && [ -n "$execs" ] && [ -n "$runs" ] &&
    [ "$execs" -lt "$runs" ]; then
    ended=time_limit
  fi
  if [ -n "$runs" ] && [ "$status" -eq 0 ] && [ "$n" -eq 0 ] && [ -n "$execs" ]; then
    save_campaign "$t" "$work" "$execs" "$secs" "${cov:-?}" "$ended" ||
      note+="  (fuzz/campaign/$t not updated: the merge failed, see $build/logs/$t.merge.log)"
  fi
  printf '%-22s %12s execs %6s s  coverage %6s  findings %s%s\n' "$t" "${execs:-?}" "$secs" \
    "${cov:-?}" "$n" "$note" >"$build/logs/$t.summary"
  if [ "$status" -ne 0 ] || [ "$n" -ne 0 ]; then
    echo 1 >"$build/logs/$t.failed"
    echo "fuzz.sh: $t FAILED (exit $status); the finding:" >&2
    grep -E 'ERROR|runtime error|SUMMARY|Test unit written' "$log" |
      head -20 >&2 || tail -30 "$log" >&2
    echo "fuzz.sh: rerun it with full stacks: $build/fuzz/${t}_fuzz $findings/<file>" >&2
  else
    echo 0 >"$build/logs/$t.failed"
  fi
}
running=0
for t in "${targets[@]}"; do
  rm -f "$build/logs/$t.summary" "$build/logs/$t.failed"
  fuzz_one "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait
failed=0
summary=()
for t in "${targets[@]}"; do
  summary+=("$(cat "$build/logs/$t.summary" 2>/dev/null || echo "$t: no result")")
  [ "$(cat "$build/logs/$t.failed" 2>/dev/null || echo 1)" = 0 ] || failed=1
done
echo "== fuzz summary =="
printf '%s\n' "${summary[@]}"
if [ -n "$runs" ] && [ -f "$ledger" ]; then
  echo "== executions on the campaign ledger (fuzz/campaign/ledger.tsv; commit fuzz/campaign/) =="
  awk -F'\t' 'NR > 1 { n[$3] += $4; r[$3]++ } END { for (t in n) printf "%-22s %12d execs in %d runs\n", t, n[t], r[t] }' \
    "$ledger" | sort
fi
exit $failed
