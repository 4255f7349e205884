#!/usr/bin/env bash
# The web page in headless chromium against a running `aoscan serve` replaying the bundled
# recording (browser_check.mjs says what is checked). Usage: browser_test.sh AOSCAN SOURCE_DIR OUT_DIR
# Exit 77 (skipped) without node, chromium or playwright-core.
set -uo pipefail
aoscan=$1; source_dir=$2; out=$3
command -v node > /dev/null || { echo "SKIP: node is not installed"; exit 77; }
rm -rf "$out" && mkdir -p "$out/data"
ln -s "$source_dir/recordings/corner" "$out/data/corner"
"$aoscan" serve --listen 127.0.0.1:0 --data "$out/data" --threads 2 2> "$out/serve.log" &
service=$!
trap 'kill $service 2> /dev/null; wait $service 2> /dev/null' EXIT
port=""
for _ in $(seq 100); do  # the service prints the port it was given
  port=$(sed -n 's#^aoscan: serving on http://127.0.0.1:\([0-9]*\)/.*#\1#p' "$out/serve.log")
  [[ -n "$port" ]] && break
  sleep 0.1
done
[[ -n "$port" ]] || { echo "FAIL: the service did not start: $(cat "$out/serve.log")"; exit 1; }
node "$source_dir/tests/serve/browser_check.mjs" "http://127.0.0.1:$port/" corner "$out"
