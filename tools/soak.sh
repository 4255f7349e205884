#!/usr/bin/env bash
# Soak benchmark (BENCHMARKS.md, "Soak"; not part of CTest or CI): replays a recording at its
# live rate (--realtime --headless) with `--loop` for M minutes, samples the process's VmRSS and
# VmHWM (/proc/PID/status), its progress and the machine's load average every few seconds into a
# CSV, and prints fps per minute, the RSS at the reference minute against the peak of the last
# minutes, the drops and the load (other jobs on the same cores cause drops).
#
# Usage: tools/soak.sh [--minutes M] [--source DIR] [--build DIR] [--out DIR] [--sample S]
#        tools/soak.sh --summary DIR      (the summary again, from DIR's samples)
#   --minutes M   minutes of frames at the recording's rate (default 60)
#   --source DIR  a TUM-layout recording (default ../shared/data/7scenes-redkitchen; the run is
#                 skipped with a message, exit 0, when it is absent), or a synth: spec, recorded
#                 into OUT/source first (a scene with exact poses in its groundtruth.txt)
#   --build DIR   a build folder; configured (Release) and aoscan built in it when needed
#                 (default build)
#   --out DIR     samples.csv, aoscan.log (progress lines) and the replay's outputs in run/
#                 (default soak-out)
#   --sample S    seconds between samples (default 5)
# The memory check compares VmRSS at minute 10 with the largest VmRSS of the replay's last ten
# minutes (pass: within 5 %; the mesh export after the last frame is reported apart); runs
# shorter than 20 minutes compare minute M/5 with the last M/5 minutes.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

minutes=60
source_dir="$root/../shared/data/7scenes-redkitchen"
build_dir="$root/build"
out_dir="soak-out"
sample_s=5
summary_only=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --minutes) minutes="$2"; shift 2 ;;
    --source) source_dir="$2"; shift 2 ;;
    --build) build_dir="$2"; shift 2 ;;
    --out) out_dir="$2"; shift 2 ;;
    --sample) sample_s="$2"; shift 2 ;;
    --summary) summary_only="$2"; shift 2 ;;
    -h|--help) sed -n '2,21p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "soak: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done

summary() {  # $1: the output folder
  python3 - "$1" <<'PY'
import csv, json, math, os, statistics, sys
out = sys.argv[1]
rows = list(csv.DictReader(open(os.path.join(out, "samples.csv"))))
meta = json.load(open(os.path.join(out, "meta.json")))
minutes = int(meta["minutes"])
# Progress lines: chain elapsed time -> frames processed / read / dropped.
prog = []
for line in open(os.path.join(out, "aoscan.log")):
    if line.startswith("aoscan: progress: "):
        f = line.split()
        prog.append((float(f[-2]), int(f[2]), int(f[5]), int(f[7])))
if not prog:
    sys.exit("soak: no progress line in " + os.path.join(out, "aoscan.log"))
def at(t):  # counts of the last progress line at or before chain time t
    best = (0.0, 0, 0, 0)
    for p in prog:
        if p[0] <= t: best = p
        else: break
    return best
full = int(prog[-1][0] // 60)
fps, drops = [], []
for m in range(1, min(full, minutes) + 1):
    a, b = at(60.0 * (m - 1)), at(60.0 * m)
    fps.append((b[1] - a[1]) / (b[0] - a[0]) if b[0] > a[0] else 0.0)
    drops.append(b[3] - a[3])
print(f"source: {meta['source']} ({meta['frames']} frames, {meta['rate_hz']:.2f} Hz), "
      f"--loop {meta['passes']}, {minutes} min planned, {prog[-1][0] / 60:.1f} min run")
if fps:
    print("fps per minute: min %.2f  median %.2f  max %.2f  (%d full minutes)"
          % (min(fps), statistics.median(fps), max(fps), len(fps)))
    print("fps by minute: " + " ".join(f"{x:.1f}" for x in fps))
    print("drops per minute: min %d  median %g  max %d" % (min(drops), statistics.median(drops), max(drops)))
loads = [float(r["load1"]) for r in rows if r.get("load1")]
if loads:
    print("machine load (1-min load average over the samples): min %.2f  median %.2f  max %.2f"
          % (min(loads), statistics.median(loads), max(loads)))
ref = 10 if minutes >= 20 else max(1, minutes // 5)
window = ref
t_ref = 60.0 * ref
# The replay ends at the first sample showing the final frame count: later samples are the mesh
# extraction and export, which the steady-state window leaves out (reported on their own).
final = rows[-1]["frames_processed"]
end_i = next(i for i, r in enumerate(rows) if r["frames_processed"] == final)
t_end = float(rows[end_i]["t_s"])
chain = rows[:end_i + 1]
ref_row = min(chain, key=lambda r: abs(float(r["t_s"]) - t_ref))
last = [r for r in chain if float(r["t_s"]) >= t_end - 60.0 * window]
rss_ref = int(ref_row["vmrss_kb"])
rss_last = max(int(r["vmrss_kb"]) for r in last)
ratio = rss_last / rss_ref
print(f"VmRSS at minute {ref} (t = {float(ref_row['t_s']):.0f} s): {rss_ref / 1024:.1f} MiB; "
      f"max of the last {window} min: {rss_last / 1024:.1f} MiB; ratio {ratio:.4f} -> "
      + ("PASS (within 5 %)" if ratio <= 1.05 else "FAIL (more than 5 % above)"))
print(f"replay ended at t = {t_end:.0f} s; VmRSS then {int(rows[end_i]['vmrss_kb']) / 1024:.1f} MiB; "
      f"VmHWM at the last sample (export included): {int(rows[-1]['vmhwm_kb']) / 1024:.1f} MiB")
stats_file = os.path.join(out, "run", "stats.json")
if os.path.exists(stats_file):
    s = json.load(open(stats_file))
    print(f"stats.json: frames_read {s['frames_read']}, frames_processed {s['frames_processed']}, "
          f"frames_dropped {s['frames_dropped']} {json.dumps(s.get('frames_dropped_at', {}))}, "
          f"frames_tracking_lost {s['frames_tracking_lost']}, fps {s['fps']:.2f}, "
          f"peak_rss_mb {s['peak_rss_mb']:.1f}, host_steal_percent {s.get('host_steal_percent')}")
    print(f"model: tsdf {json.dumps(s['tsdf'])}, mvao_grid cells {s['mvao_grid']['cells']} "
          f"({s['mvao_grid']['memory_mb']:.1f} MB)")
PY
}

if [[ -n "$summary_only" ]]; then
  summary "$summary_only"
  exit 0
fi

if [[ "$source_dir" != synth:* && ! -f "$source_dir/depth.txt" ]]; then
  echo "soak: skipped: no recording at $source_dir (give one with --source DIR)"
  exit 0
fi
if [[ ! -x "$build_dir/aoscan" ]]; then
  cmake -S "$root" -B "$build_dir" -DCMAKE_BUILD_TYPE=Release > /dev/null
fi
cmake --build "$build_dir" --target aoscan -j "$(nproc)" > /dev/null

mkdir -p "$out_dir"
if [[ "$source_dir" == synth:* ]]; then
  # A synthetic scene is recorded once (its frames rendered ahead, so that the replay's capture
  # costs what a recording's does) and looped like one; kept for the next run of the same spec.
  spec="$source_dir"
  source_dir="$out_dir/source"
  if [[ "$(cat "$source_dir/spec.txt" 2> /dev/null)" != "$spec" ]]; then
    rm -rf "$source_dir"
    echo "soak: recording $spec into $source_dir"
    "$build_dir/aoscan" record "$spec" "$source_dir" > /dev/null
    echo "$spec" > "$source_dir/spec.txt"
  fi
fi

# Frames per pass and the pass's length at the recorded rate (a pass of n frames spans n times
# the mean spacing: the turn adds one spacing).
read -r frames first last < <(awk '!/^#/ && NF >= 2 { if (!n) f = $1; l = $1; n++ }
                                   END { print n, f, l }' "$source_dir/depth.txt")
read -r rate pass_s passes < <(awk -v n="$frames" -v f="$first" -v l="$last" -v m="$minutes" \
  'BEGIN { d = (n > 1 && l > f) ? (l - f) / (n - 1) : 1 / 30; p = n * d;
           k = int(m * 60 / p); if (k * p < m * 60) k++; print 1 / d, p, k }')

rm -rf "$out_dir/run"
printf '{"source": "%s", "frames": %s, "rate_hz": %s, "pass_s": %s, "passes": %s, "minutes": %s}\n' \
  "$source_dir" "$frames" "$rate" "$pass_s" "$passes" "$minutes" > "$out_dir/meta.json"
echo "soak: $source_dir: $frames frames at $rate Hz, --loop $passes ($minutes min); samples every" \
     "${sample_s} s in $out_dir/samples.csv"

"$build_dir/aoscan" replay "$source_dir" --realtime --headless --loop "$passes" \
  --progress-every 1 --out "$out_dir/run" > "$out_dir/stdout.txt" 2> "$out_dir/aoscan.log" &
pid=$!
trap 'kill "$pid" 2> /dev/null || true' INT TERM
start=$(date +%s.%N)
echo "t_s,vmrss_kb,vmhwm_kb,frames_processed,frames_read,frames_dropped,load1" > "$out_dir/samples.csv"
while kill -0 "$pid" 2> /dev/null; do
  status=$(cat "/proc/$pid/status" 2> /dev/null) || break
  rss=$(awk '/^VmRSS:/ { print $2 }' <<< "$status")
  hwm=$(awk '/^VmHWM:/ { print $2 }' <<< "$status")
  [[ -n "$rss" ]] || break  # exiting
  line=$(grep '^aoscan: progress: ' "$out_dir/aoscan.log" | tail -n 1 || true)
  read -r processed readn dropped < <(awk '{ if (NF) print $3, $6, $8; else print 0, 0, 0 }' \
                                      <<< "${line:-}")
  t=$(awk -v s="$start" -v n="$(date +%s.%N)" 'BEGIN { printf "%.1f", n - s }')
  load=$(cut -d ' ' -f 1 /proc/loadavg)
  echo "$t,$rss,$hwm,${processed:-0},${readn:-0},${dropped:-0},$load" >> "$out_dir/samples.csv"
  sleep "$sample_s"
done
rc=0
wait "$pid" || rc=$?
if [[ $rc -ne 0 ]]; then
  echo "soak: aoscan exited with $rc:" >&2
  grep -v '^aoscan: progress: ' "$out_dir/aoscan.log" | tail -n 5 >&2
  exit 1
fi
summary "$out_dir"
