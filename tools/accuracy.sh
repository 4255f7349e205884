#!/usr/bin/env bash
# Synthetic accuracy table (BENCHMARKS.md, "Accuracy"): records each synth: scene, replays it
# headless, and prints one Markdown row per scene with ATE, lost frames and mesh accuracy (the mesh
# mapped by the first frame's true pose, and for comparison by the trajectory's ATE alignment).
# Usage: tools/accuracy.sh [WORK_DIR] [SPEC...]   (run from the repository root after building
# aoscan and aoscan-eval; WORK_DIR defaults to a temporary folder; default SPECs below)
set -euo pipefail

work="${1:-$(mktemp -d)}"
shift || true
specs=("$@")
if [[ ${#specs[@]} -eq 0 ]]; then
  for scene in corner room; do
    for trajectory in orbit sweep; do
      for seed in 1 2 3; do
        specs+=("synth:${scene}?frames=300&noise=kinect&seed=${seed}&trajectory=${trajectory}")
      done
    done
  done
fi

bin="$(pwd)/build"
mkdir -p "$work"
echo "| source | ATE rmse (mm) | ATE max (mm) | lost | mesh mean (mm) | mesh median (mm) | completeness (1 cm) | mesh mean, ATE map (mm) |"
echo "|---|---|---|---|---|---|---|---|"
i=0
for spec in "${specs[@]}"; do
  i=$((i + 1))
  rec="$work/rec$i"
  out="$work/out$i"
  rm -rf "$rec" "$out"
  "$bin/aoscan" record "$spec" "$rec" 2>/dev/null
  "$bin/aoscan" replay "$rec" --headless --no-progress --out "$out"
  ate=$("$bin/aoscan-eval" --json trajectory "$rec/groundtruth.txt" "$out/trajectory.txt")
  mesh=$("$bin/aoscan-eval" --json mesh "$out/mesh.ply" "$rec/scene.ply" \
           --groundtruth "$rec/groundtruth.txt" --estimate "$out/trajectory.txt")
  mesh_ate=$("$bin/aoscan-eval" --json mesh "$out/mesh.ply" "$rec/scene.ply" \
               --groundtruth "$rec/groundtruth.txt" --estimate "$out/trajectory.txt" --alignment ate)
  lost=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["frames_tracking_lost"])' \
           "$out/stats.json")
  python3 - "$spec" "$lost" "$ate" "$mesh" "$mesh_ate" <<'EOF'
import json, sys
spec, lost = sys.argv[1], sys.argv[2]
ate, mesh, mesh_ate = (json.loads(a) for a in sys.argv[3:6])
print(f"| `{spec}` | {ate['ate_rmse_m'] * 1e3:.2f} | {ate['ate_max_m'] * 1e3:.2f} | {lost} | "
      f"{mesh['accuracy_mean_m'] * 1e3:.2f} | {mesh['accuracy_median_m'] * 1e3:.2f} | "
      f"{mesh['completeness'] * 100:.1f} % | {mesh_ate['accuracy_mean_m'] * 1e3:.2f} |")
EOF
done
