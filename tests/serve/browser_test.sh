#!/usr/bin/env bash
# The web page in headless chromium against a running `aoscan serve` replaying the bundled
# recording (browser_check.mjs says what is checked). Usage: browser_test.sh AOSCAN SOURCE_DIR OUT_DIR
# Exit 77 (skipped) without node, chromium or playwright-core. A failed check is tried once more
# on a fresh service (a browser on a loaded machine can miss a deadline); both reasons are printed.
set -uo pipefail
aoscan=$1; source_dir=$2; out=$3
command -v node > /dev/null || { echo "SKIP: node is not installed"; exit 77; }

attempt() {  # one service, one browser check; the check's exit code
  local dir=$1
  rm -rf "$dir" && mkdir -p "$dir/data"
  ln -s "$source_dir/recordings/corner" "$dir/data/corner"
  "$aoscan" serve --listen 127.0.0.1:0 --data "$dir/data" --threads 2 2> "$dir/serve.log" &
  local service=$! port=""
  for _ in $(seq 100); do  # the service prints the port it was given
    port=$(sed -n 's#^aoscan: serving on http://127.0.0.1:\([0-9]*\)/.*#\1#p' "$dir/serve.log")
    [[ -n "$port" ]] && break
    sleep 0.1
  done
  local status=1
  if [[ -n "$port" ]]; then
    node "$source_dir/tests/serve/browser_check.mjs" "http://127.0.0.1:$port/" corner "$dir"
    status=$?
  else
    echo "FAIL: the service did not start: $(cat "$dir/serve.log")"
  fi
  kill "$service" 2> /dev/null
  wait "$service" 2> /dev/null
  if [[ $status -eq 1 ]]; then
    echo "the service's log:"
    tail -n 20 "$dir/serve.log"
  fi
  return $status
}

attempt "$out"
status=$?
if [[ $status -eq 1 ]]; then
  echo "trying once more"
  attempt "$out/again"
  status=$?
fi
exit $status
