#!/usr/bin/env bash
# Installs dependencies, builds aoscan and its tests, and runs the whole suite with CTest.
# Usage: tools/test.sh            Release build in build/
#        tools/test.sh --sanitize AddressSanitizer + UndefinedBehaviorSanitizer build in build-asan/
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

build_dir=build
flags=(-DCMAKE_BUILD_TYPE=Release)
if [[ "${1:-}" == "--sanitize" ]]; then
  build_dir=build-asan
  # -O1 keeps Eigen-heavy tests quick and the build short; asserts stay on.
  flags=(-DCMAKE_BUILD_TYPE=Debug "-DCMAKE_CXX_FLAGS_DEBUG=-O1" -DAOSCAN_SANITIZE=ON)
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
  export LSAN_OPTIONS="suppressions=$root/tools/lsan.supp"
  export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
fi

tools/install-deps.sh --tests
cmake -S . -B "$build_dir" "${flags[@]}" -DAOSCAN_BUILD_TESTS=ON > /dev/null
cmake --build "$build_dir" -j "$(nproc)"
# The render tests need an OpenGL 3.3 context: give the suite its own virtual X server (Mesa's
# llvmpipe renders in software; -noreset keeps it from resetting between test processes). Without
# xvfb-run the GL tests skip with a message.
ctest_cmd=(ctest --test-dir "$build_dir" --output-on-failure -j "$(nproc)")
if command -v xvfb-run > /dev/null; then
  xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" "${ctest_cmd[@]}"
else
  echo "xvfb-run not found: GL tests will skip" >&2
  "${ctest_cmd[@]}"
fi
