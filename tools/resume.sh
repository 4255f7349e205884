#!/usr/bin/env bash
# A recording replayed as one take and as two (the first saved with --save-session, the second
# continued with --resume): the ATE of both against the recording's ground truth, and the mesh of
# two takes against the one take's (BENCHMARKS.md, "Sessions"). With a synth: recording the meshes
# are also scored against the exact scene.
# Usage: tools/resume.sh [--split N] [--work DIR] SOURCE
#   SOURCE: a TUM folder with groundtruth.txt (e.g. ../shared/data/7scenes-redkitchen) or a
#   synth: spec, recorded first. Frames [0, N) are the first take, the rest the second (default:
#   half). Run from the repository root after building aoscan, aoscan-eval and aoscan-mesh-compare.
set -euo pipefail

split=""
work=""
while [[ $# -gt 1 ]]; do
  case "$1" in
    --split) split="$2"; shift 2 ;;
    --work) work="$2"; shift 2 ;;
    *) echo "tools/resume.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
[[ $# -eq 1 ]] || { echo "usage: tools/resume.sh [--split N] [--work DIR] SOURCE" >&2; exit 2; }
source_arg="$1"
bin="$(pwd)/build"
work="${work:-$(mktemp -d)}"
mkdir -p "$work"

rec="$source_arg"
if [[ "$source_arg" == synth:* ]]; then
  rec="$work/recording"
  rm -rf "$rec"
  "$bin/aoscan" record "$source_arg" "$rec" 2>/dev/null
fi
rec="$(cd "$rec" && pwd)"
[[ -f "$rec/depth.txt" && -f "$rec/groundtruth.txt" ]] ||
  { echo "tools/resume.sh: $rec needs depth.txt and groundtruth.txt" >&2; exit 2; }

# The two takes as folders of their own: the same files, each listing its part of depth.txt.
frames=$(grep -cv '^#' "$rec/depth.txt")
split="${split:-$((frames / 2))}"
for take in 1 2; do
  dir="$work/take$take"
  rm -rf "$dir"
  mkdir -p "$dir"
  for f in "$rec"/*; do
    [[ "$(basename "$f")" == depth.txt ]] || ln -s "$f" "$dir/"
  done
  if [[ $take == 1 ]]; then
    grep -v '^#' "$rec/depth.txt" | head -n "$split" > "$dir/depth.txt"
  else
    grep -v '^#' "$rec/depth.txt" | tail -n "+$((split + 1))" > "$dir/depth.txt"
  fi
done

run() { "$bin/aoscan" replay "$@" --headless --no-progress 2> "$work/log.txt" ||
          { cat "$work/log.txt" >&2; exit 1; }; }
rm -rf "$work/one" "$work/first" "$work/both"
run "$rec" --out "$work/one"
run "$work/take1" --out "$work/first" --save-session
run "$work/take2" --out "$work/both" --resume "$work/first" --save-session

echo "frames: $frames, takes: 0-$((split - 1)) and $split-$((frames - 1))"
for out in one both; do
  python3 - "$out" "$work/$out/stats.json" \
    "$("$bin/aoscan-eval" --json trajectory "$rec/groundtruth.txt" "$work/$out/trajectory.txt")" <<'EOF'
import json, sys
name, stats, ate = sys.argv[1], json.load(open(sys.argv[2])), json.loads(sys.argv[3])
print(f"{name}: ATE {ate['ate_rmse_m'] * 1e3:.2f} mm (max {ate['ate_max_m'] * 1e3:.2f}), "
      f"{stats['frames_tracking_lost']} lost, {stats['relocalisations']} relocalised, "
      f"{stats['mesh']['vertices']} vertices")
EOF
done
# Mesh figures: NAME and the JSON of aoscan-eval mesh.
mesh_line() {
  python3 - "$1" "$2" <<'PY'
import json, sys
m = json.loads(sys.argv[2])
print(f"{sys.argv[1]}: vertex distance mean {m['accuracy_mean_m'] * 1e3:.3f} mm, median "
      f"{m['accuracy_median_m'] * 1e3:.3f} mm, completeness (1 cm) {m['completeness'] * 100:.1f} %")
PY
}
# The two takes' mesh scored against the one take's (both worlds are the first frame's camera:
# the map between them is the identity).
mesh_line "two takes against the one take's mesh" "$("$bin/aoscan-eval" --json mesh \
  "$work/both/mesh.ply" "$work/one/mesh.ply" \
  --groundtruth "$work/one/trajectory.txt" --estimate "$work/both/trajectory.txt")"
if [[ -f "$rec/scene.ply" ]]; then
  for out in one both; do
    mesh_line "$out against the scene" "$("$bin/aoscan-eval" --json mesh "$work/$out/mesh.ply" \
      "$rec/scene.ply" --groundtruth "$rec/groundtruth.txt" --estimate "$work/$out/trajectory.txt")"
  done
fi
