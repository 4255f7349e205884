#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ (clang, ASan + UBSan) and runs every target, two at a time.
# Usage: tools/fuzz.sh [--seconds N | --runs N] [--jobs J] [--max-len B] [--continue] [--merge]
#                      [--build-dir DIR] [--build-only] [TARGET...]
#   --seconds N    fuzz each target for N seconds (default 60; the short form: README, Fuzzing)
#   --runs N       fuzz each target for N executions (the long campaign: --runs 10000000); given
#                  with --seconds, a target stops at whichever comes first
#   --jobs J       targets fuzzed at once (default 2)
#   --max-len B    the longest input, in bytes (default 8192; the YAML targets' campaign: 2048)
#   --continue     go on from the corpus the last run of a target left in D/runs/TARGET/ instead
#                  of a fresh copy, counting its executions: with --runs N, a campaign cut short
#                  (a stop, a reboot) resumes until N executions in all
#   --merge        afterwards, add the inputs that found new coverage to fuzz/corpus/TARGET/
#                  (minimised with libFuzzer's -merge=1)
#   --build-dir D  where to build and run (default build-fuzz)
#   --build-only   build the targets, fuzz nothing
#   TARGET...      only these targets (default: all of fuzz/CMakeLists.txt)
# Each target fuzzes a fresh copy of fuzz/corpus/TARGET/ (unless --continue; the repository's
# corpus is never rewritten except by --merge) with fuzz/TARGET.dict, or the dictionary of the name's first word
# (config_json uses fuzz/config.dict). Its log is D/runs/TARGET/log.txt; a crash, leak, timeout
# (10 s per input) or out-of-memory input (2 GB) is kept as D/runs/TARGET/{crash,leak,timeout,oom}-*
# and makes the script exit 1. Reproduce one with: D/TARGET_fuzz D/runs/TARGET/crash-...
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

seconds=""
runs=""
jobs=2
max_len=8192
merge=0
continue=0
build_only=0
build_dir=build-fuzz
only=()
usage() { sed -n '2,/^set -euo/{/^#/p}' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }
while [[ $# -gt 0 ]]; do
  case "$1" in
    --seconds) seconds="${2:?}"; shift 2 ;;
    --runs) runs="${2:?}"; shift 2 ;;
    --jobs) jobs="${2:?}"; shift 2 ;;
    --max-len) max_len="${2:?}"; shift 2 ;;
    --continue) continue=1; shift ;;
    --merge) merge=1; shift ;;
    --build-dir) build_dir="${2:?}"; shift 2 ;;
    --build-only) build_only=1; shift ;;
    -h|--help) usage ;;
    -*) usage ;;
    *) only+=("$1"); shift ;;
  esac
done

if [[ -z "$runs" && -z "$seconds" ]]; then seconds=60; fi

tools/install-deps.sh --fuzz
build_start=$(date +%s)
# -O2 with assertions on (no NDEBUG): fast executions that still check the code's own asserts.
CC=clang CXX=clang++ cmake -S . -B "$build_dir" -DAOSCAN_FUZZ=ON -DCMAKE_BUILD_TYPE=Debug \
  "-DCMAKE_CXX_FLAGS_DEBUG=-O2 -g" > /dev/null
cmake --build "$build_dir" -j "$(nproc)"
echo "fuzz build: $(( $(date +%s) - build_start )) s"
build_dir="$(cd "$build_dir" && pwd)"
[[ "$build_only" == 1 ]] && exit 0

if [[ ${#only[@]} -gt 0 ]]; then
  targets=("${only[@]}")
else
  mapfile -t targets < "$build_dir/fuzz_targets.txt"
fi

# A 64 MB quarantine (ASan's default: 256 MB) still catches a use after free within many
# inputs, and keeps the parsers' small allocations in cache: about 3x the executions per second.
# No allocation stacks are recorded (malloc_context_size=0; 1.2x the YAML targets' executions per
# second): a finding's report names where it happened, and reproducing its input outside this
# script (D/TARGET_fuzz FILE, ASan's default options) gives where the memory was allocated and
# freed.
export ASAN_OPTIONS="detect_leaks=1:quarantine_size_mb=64:malloc_context_size=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

# Executions a libFuzzer log reports: the final statistics, or the last status line ("#N ...")
# of a run that was killed before it printed them.
executions_in() {
  local n
  n=$(grep -m1 '^stat::number_of_executed_units:' "$1" 2> /dev/null | awk '{print $2}' || true)
  [[ -n "$n" ]] || n=$(grep -o '^#[0-9]*' "$1" 2> /dev/null | tail -n1 | tr -d '#' || true)
  echo "${n:-0}"
}

# Fuzzes one target in D/runs/TARGET/; writes its exit status to status.txt there. With
# --continue, the earlier runs' executions and seconds are in done.txt ("EXECUTIONS SECONDS") and
# their logs in log.N.txt.
fuzz_one() {
  local t="$1"
  local dir="$build_dir/runs/$t"
  local done_execs=0 done_secs=0
  if [[ "$continue" == 1 && -d "$dir/corpus" ]]; then
    [[ -f "$dir/done.txt" ]] && read -r done_execs done_secs < "$dir/done.txt"
    if [[ -f "$dir/log.txt" ]]; then
      done_execs=$(( done_execs + $(executions_in "$dir/log.txt") ))
      # A run killed before it wrote seconds.txt: from its start to its log's last write.
      local secs
      secs=$(cat "$dir/seconds.txt" 2> /dev/null ||
             echo $(( $(stat -c %Y "$dir/log.txt") - $(cat "$dir/started.txt" 2> /dev/null ||
                                                         stat -c %Y "$dir/log.txt") )))
      done_secs=$(( done_secs + secs ))
      local n=1
      while [[ -f "$dir/log.$n.txt" ]]; do n=$(( n + 1 )); done
      mv "$dir/log.txt" "$dir/log.$n.txt"
      rm -f "$dir/seconds.txt" "$dir/status.txt"
    fi
    echo "$done_execs $done_secs" > "$dir/done.txt"
  else
    rm -rf "$dir"
    mkdir -p "$dir/corpus"
    if [[ -d "fuzz/corpus/$t" ]]; then cp -r "fuzz/corpus/$t/." "$dir/corpus/"; fi
  fi
  local args=(-timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=2048 "-max_len=$max_len"
              -print_final_stats=1 "-artifact_prefix=$dir/")
  if [[ -n "$runs" ]]; then
    if (( done_execs >= runs )); then echo 0 > "$dir/status.txt"; return; fi
    args+=("-runs=$(( runs - done_execs ))")
  fi
  if [[ -n "$seconds" ]]; then args+=("-max_total_time=$seconds"); fi
  local dict="fuzz/$t.dict"
  [[ -f "$dict" ]] || dict="fuzz/${t%%_*}.dict"
  if [[ -f "$dict" ]]; then args+=("-dict=$dict"); fi
  local start status=0
  start=$(date +%s)
  echo "$start" > "$dir/started.txt"
  "$build_dir/${t}_fuzz" "${args[@]}" "$dir/corpus" > "$dir/log.txt" 2>&1 || status=$?
  echo "$(( $(date +%s) - start ))" > "$dir/seconds.txt"
  echo "$status" > "$dir/status.txt"
}

echo "fuzzing ${#targets[@]} targets, $jobs at a time, each for" \
     "${runs:+$runs executions}${runs:+${seconds:+ or }}${seconds:+$seconds s}"
running=0
for t in "${targets[@]}"; do
  [[ -x "$build_dir/${t}_fuzz" ]] || { echo "no fuzz target '$t'" >&2; exit 2; }
  if (( running >= jobs )); then
    wait -n || true
    running=$(( running - 1 ))
  fi
  fuzz_one "$t" &
  running=$(( running + 1 ))
done
wait || true

failed=0
printf '%-16s %12s %8s %8s %10s %7s  %s\n' target executions exec/s seconds cov corpus result
for t in "${targets[@]}"; do
  dir="$build_dir/runs/$t"
  # A continued campaign: its totals, coverage from its first log to its last.
  done_execs=0 done_secs=0
  [[ -f "$dir/done.txt" ]] && read -r done_execs done_secs < "$dir/done.txt"
  first_log="$dir/log.txt" log="$dir/log.txt"
  [[ -f "$dir/log.1.txt" ]] && first_log="$dir/log.1.txt"
  if [[ ! -f "$log" ]]; then log=$(ls -v "$dir"/log.*.txt 2> /dev/null | tail -n1 || true); fi
  status=$(cat "$dir/status.txt" 2> /dev/null || echo 1)
  execs=$(( done_execs + $(executions_in "$dir/log.txt") ))  # no log.txt: 0, all in done.txt
  secs=$(( done_secs + $(cat "$dir/seconds.txt" 2> /dev/null || echo 0) ))
  rate=$(( execs / (secs > 0 ? secs : 1) ))
  cov_start=$(grep -m1 -o 'INITED cov: [0-9]*' "$first_log" | awk '{print $3}' || true)
  cov_end=$(grep -o 'cov: [0-9]*' "$log" | tail -n1 | awk '{print $2}' || true)
  corpus=$(find "$dir/corpus" -type f | wc -l)
  artifacts=$(find "$dir" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' \
              -o -name 'timeout-*' -o -name 'oom-*' \) | tr '\n' ' ')
  result=ok
  if [[ "$status" != 0 || -n "$artifacts" ]]; then
    result="FAILED (exit $status) ${artifacts:-see $log}"
    failed=1
  fi
  printf '%-16s %12s %8s %8s %10s %7s  %s\n' "$t" "$execs" "$rate" "$secs" \
         "${cov_start:-?}->${cov_end:-?}" \
         "$corpus" "$result"
  if [[ "$merge" == 1 && "$result" == ok ]]; then
    mkdir -p "fuzz/corpus/$t"
    "$build_dir/${t}_fuzz" -merge=1 "fuzz/corpus/$t" "$dir/corpus" > "$dir/merge.txt" 2>&1
    echo "  merged: $(grep -o 'added [0-9]* new units' "$dir/merge.txt" || echo 'see merge.txt')"
  fi
done
if [[ "$failed" != 0 ]]; then
  echo "fuzzing found a bug: reproducers are in $build_dir/runs/*/ (run D/TARGET_fuzz FILE)" >&2
  exit 1
fi
