#!/usr/bin/env bash
# Installs dependencies, builds aoscan (Release) and replays the bundled recording into aoscan-out/.
# Usage: tools/demo.sh [extra replay options]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

tools/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DAOSCAN_BUILD_TESTS=OFF > /dev/null
cmake --build build -j "$(nproc)" --target aoscan

headless=()
if [[ -z "${DISPLAY:-}" && -z "${WAYLAND_DISPLAY:-}" ]]; then
  headless=(--headless)
fi
build/aoscan replay recordings/corner --out aoscan-out "${headless[@]}" "$@"
echo "Outputs in $root/aoscan-out:"
ls -l aoscan-out
