#!/usr/bin/env bash
# Installs dependencies, builds aoscan and its tests, and runs the whole suite with CTest.
# Usage: tools/test.sh            Release build in build/
#        tools/test.sh --sanitize AddressSanitizer + UndefinedBehaviorSanitizer build in build-asan/
#        tools/test.sh --sanitize SUITE...  the same for some suites only (io, ao, pipeline, ...:
#                                 the folders of tests/; CI leaves out app and render)
#        tools/test.sh --tsan     ThreadSanitizer build in build-tsan/ of the suites that start
#                                 threads (not in CI: it does not fit its time budget)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

build_dir=build
flags=(-DCMAKE_BUILD_TYPE=Release)
# aoscan, the suites and the tools they run; the benchmarks are left to `cmake --build build`
# (README, Benchmarks), which CI does not need.
targets=(aoscan aoscan_tests)
if [[ "${1:-}" == "--sanitize" ]]; then
  build_dir=build-asan
  # -O1 keeps Eigen-heavy tests quick and the build short; asserts stay on.
  flags=(-DCMAKE_BUILD_TYPE=Debug "-DCMAKE_CXX_FLAGS_DEBUG=-O1" -DAOSCAN_SANITIZE=ON)
  # The suites and what they run; the benchmarks and evaluation tools are built by the Release run.
  targets=(aoscan_tests)
  shift
  if [[ $# -gt 0 ]]; then
    targets=()
    for suite in "$@"; do targets+=("${suite}_tests"); done
    only_labels="^($(IFS='|'; echo "$*"))\$"
  fi
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
  export LSAN_OPTIONS="suppressions=$root/tools/lsan.supp"
  export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
elif [[ "${1:-}" == "--tsan" ]]; then
  build_dir=build-tsan
  flags=(-DCMAKE_BUILD_TYPE=Debug "-DCMAKE_CXX_FLAGS_DEBUG=-O1 -g" -DAOSCAN_TSAN=ON)
  # The suites whose code runs on more than one thread: the stage chain and its queues
  # (pipeline), the capture threads of the cameras and the recorder (capture), and the command
  # line end to end (app: the whole chain in a ThreadSanitizer build of aoscan).
  targets=(capture_tests pipeline_tests app_tests)
  export TSAN_OPTIONS="suppressions=$root/tools/tsan.supp halt_on_error=1 second_deadlock_stack=1"
fi

tools/install-deps.sh --tests
cmake -S . -B "$build_dir" "${flags[@]}" -DAOSCAN_BUILD_TESTS=ON > /dev/null
if [[ -n "${targets:-}" ]]; then
  cmake --build "$build_dir" -j "$(nproc)" --target "${targets[@]}"
else
  cmake --build "$build_dir" -j "$(nproc)"
fi
# The render tests need an OpenGL 3.3 context: give the suite its own virtual X server (Mesa's
# llvmpipe renders in software; -noreset keeps it from resetting between test processes). Without
# xvfb-run the GL tests skip with a message.
ctest_cmd=(ctest --test-dir "$build_dir" --output-on-failure -j "$(nproc)")
# Suites left unbuilt (--tsan) register a *_NOT_BUILT placeholder: skip those.
[[ -n "${targets:-}" ]] && ctest_cmd+=(-E '_NOT_BUILT$')
[[ -n "${only_labels:-}" ]] && ctest_cmd+=(-L "$only_labels")
if command -v xvfb-run > /dev/null; then
  xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" "${ctest_cmd[@]}"
else
  echo "xvfb-run not found: GL tests will skip" >&2
  "${ctest_cmd[@]}"
fi
