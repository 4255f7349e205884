#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ (clang, ASan + UBSan) and runs every target, two at a time.
# Usage: tools/fuzz.sh [--seconds N | --runs N] [--jobs J] [--merge] [--build-dir DIR] [TARGET...]
#   --seconds N    fuzz each target for N seconds (default 60; the short form: README, Fuzzing)
#   --runs N       fuzz each target for N executions (the long campaign: --runs 10000000); given
#                  with --seconds, a target stops at whichever comes first
#   --jobs J       targets fuzzed at once (default 2)
#   --merge        afterwards, add the inputs that found new coverage to fuzz/corpus/TARGET/
#                  (minimised with libFuzzer's -merge=1)
#   --build-dir D  where to build and run (default build-fuzz)
#   TARGET...      only these targets (default: all of fuzz/CMakeLists.txt)
# Each target fuzzes a fresh copy of fuzz/corpus/TARGET/ (the repository's corpus is never
# rewritten except by --merge) with fuzz/TARGET.dict, or the dictionary of the name's first word
# (config_json uses fuzz/config.dict). Its log is D/runs/TARGET/log.txt; a crash, leak, timeout
# (10 s per input) or out-of-memory input (2 GB) is kept as D/runs/TARGET/{crash,leak,timeout,oom}-*
# and makes the script exit 1. Reproduce one with: D/TARGET_fuzz D/runs/TARGET/crash-...
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

seconds=""
runs=""
jobs=2
merge=0
build_dir=build-fuzz
only=()
usage() { sed -n '2,18p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }
while [[ $# -gt 0 ]]; do
  case "$1" in
    --seconds) seconds="${2:?}"; shift 2 ;;
    --runs) runs="${2:?}"; shift 2 ;;
    --jobs) jobs="${2:?}"; shift 2 ;;
    --merge) merge=1; shift ;;
    --build-dir) build_dir="${2:?}"; shift 2 ;;
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

if [[ ${#only[@]} -gt 0 ]]; then
  targets=("${only[@]}")
else
  mapfile -t targets < "$build_dir/fuzz_targets.txt"
fi

# A 64 MB quarantine (ASan's default: 256 MB) still catches a use after free within many
# inputs, and keeps the parsers' small allocations in cache: about 3x the executions per second.
export ASAN_OPTIONS="detect_leaks=1:quarantine_size_mb=64"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

# Fuzzes one target in D/runs/TARGET/; writes its exit status to status.txt there.
fuzz_one() {
  local t="$1"
  local dir="$build_dir/runs/$t"
  rm -rf "$dir"
  mkdir -p "$dir/corpus"
  if [[ -d "fuzz/corpus/$t" ]]; then cp -r "fuzz/corpus/$t/." "$dir/corpus/"; fi
  local args=(-timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=2048 -max_len=8192
              -print_final_stats=1 "-artifact_prefix=$dir/")
  if [[ -n "$runs" ]]; then args+=("-runs=$runs"); fi
  if [[ -n "$seconds" ]]; then args+=("-max_total_time=$seconds"); fi
  local dict="fuzz/$t.dict"
  [[ -f "$dict" ]] || dict="fuzz/${t%%_*}.dict"
  if [[ -f "$dict" ]]; then args+=("-dict=$dict"); fi
  local start status=0
  start=$(date +%s)
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

final_stat() { grep -m1 "^stat::$1:" "$2" | awk '{print $2}' || true; }
failed=0
printf '%-16s %12s %8s %8s %10s %7s  %s\n' target executions exec/s seconds cov corpus result
for t in "${targets[@]}"; do
  dir="$build_dir/runs/$t"
  log="$dir/log.txt"
  status=$(cat "$dir/status.txt" 2> /dev/null || echo 1)
  execs=$(final_stat number_of_executed_units "$log")
  rate=$(final_stat average_exec_per_sec "$log")
  cov_start=$(grep -m1 -o 'INITED cov: [0-9]*' "$log" | awk '{print $3}' || true)
  cov_end=$(grep -o 'cov: [0-9]*' "$log" | tail -n1 | awk '{print $2}' || true)
  corpus=$(find "$dir/corpus" -type f | wc -l)
  artifacts=$(find "$dir" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' \
              -o -name 'timeout-*' -o -name 'oom-*' \) | tr '\n' ' ')
  result=ok
  if [[ "$status" != 0 || -n "$artifacts" ]]; then
    result="FAILED (exit $status) ${artifacts:-see $log}"
    failed=1
  fi
  printf '%-16s %12s %8s %8s %10s %7s  %s\n' "$t" "${execs:-?}" "${rate:-?}" \
         "$(cat "$dir/seconds.txt" 2> /dev/null || echo '?')" "${cov_start:-?}->${cov_end:-?}" \
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
