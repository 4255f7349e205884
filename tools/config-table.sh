#!/usr/bin/env bash
# Prints the configuration keys as the Markdown table of the README: tools/config-table.sh [aoscan]
set -euo pipefail
aoscan="${1:-build/aoscan}"
echo "| key | default | meaning |"
echo "|---|---|---|"
"$aoscan" config | awk '
  /^[^ ]/ { sub(":", "", $1); section = $1; next }
  {
    line = $0; sub(/^  /, "", line)
    key = line; sub(/:.*/, "", key)
    rest = line; sub(/^[^:]*: /, "", rest)
    value = rest; sub(/  # .*/, "", value)
    doc = rest; sub(/^.*  # /, "", doc)
    printf "| `%s.%s` | %s | %s |\n", section, key, value, doc
  }'
