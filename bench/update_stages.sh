#!/usr/bin/env bash
# What one filter update costs, stage by stage (docs/architecture.md, "One filter update"): the demo's office and
# test route (simulated once into OUT and reused), localized globally with --particles N. From report.json it prints
# one JSON line per phase: "global" (the updates at 50,000 particles or more: the search) and "tracking" (from the
# first converged update on), each with its update count, the median particles, the median of every stage and of
# update_total (preprocessing, before the update, apart), the median time beside the sensor update
# (beyond_weighting_ms: the total less upload and weight, the host side), and untimed_share (the median over the
# updates of 1 - the stages' sum over update_total).
#
#   bash bench/update_stages.sh [--cli PATH] [--out DIR] [--particles 50000,100000] [--backend cpu] [--seed 1]
set -euo pipefail
cd "$(dirname "$0")/.."

cli=build/release/tools/tsdf-mcl
out=out/update_stages
particles=50000,100000
backend=cpu
seed=1
while [ $# -gt 0 ]; do
  case "$1" in
    --cli) cli="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --particles) particles="$2"; shift 2 ;;
    --backend) backend="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "update_stages.sh: unknown option $1 (--help lists them)" >&2; exit 2 ;;
  esac
done
[ -x "$cli" ] || { echo "update_stages.sh: no program at $cli (build first, or --cli PATH)" >&2; exit 2; }

mkdir -p "$out"
if [ ! -f "$out/office.tsdf" ]; then
  "$cli" simulate --scene office --lidar vlp16 --route mapping --seed 1 --quiet -o "$out/mapping"
  "$cli" build-map --dataset "$out/mapping" --quiet -o "$out/office.tsdf"
fi
[ -d "$out/test" ] || "$cli" simulate --scene office --lidar vlp16 --route test --seed 1 --quiet -o "$out/test"

for n in ${particles//,/ }; do
  run="$out/run-$n"
  "$cli" localize --map "$out/office.tsdf" --dataset "$out/test" --init global --particles "$n" \
    --backend "$backend" --seed "$seed" --overwrite --quiet -o "$run"
  python3 - "$run/report.json" "$n" <<'PY'
import json, statistics, sys

report, particles = json.load(open(sys.argv[1])), int(sys.argv[2])
updates = [s for s in report["scans"] if s.get("updated")]
first = next((i for i, s in enumerate(updates) if s.get("converged")), None)
phases = {
    "global": [s for s in updates if s["particles"] >= 50000],
    "tracking": updates[first:] if first is not None else [],
}
# The update's stages (filter_core's StepTimings); weight_gpu and reduce_gpu are the GPU's share of weight, load and
# preprocess come before the update.
STAGES = ("motion", "upload", "weight", "walls", "own_points", "tempering", "places", "ledger", "decision", "resample")

def untimed(scan):
    t = scan["timings_ms"]
    staged = sum(t.get(k) or 0.0 for k in STAGES)
    return 1.0 - staged / t["update_total"] if t["update_total"] > 0 else 0.0

for phase, scans in phases.items():
    if not scans:
        continue
    def median(key):
        return statistics.median(s["timings_ms"].get(key) or 0.0 for s in scans)
    stages = {k: round(median(k), 3) for k in STAGES}
    total = median("update_total")
    host = statistics.median(
        s["timings_ms"]["update_total"] - (s["timings_ms"].get("upload") or 0) - (s["timings_ms"].get("weight") or 0)
        for s in scans)
    print(json.dumps({
        "bench": "update_stages", "initial_particles": particles, "phase": phase, "updates": len(scans),
        "median_particles": statistics.median(s["particles"] for s in scans), "backend": report.get("backend"),
        "stages_ms": stages, "update_total_ms": round(total, 3), "beyond_weighting_ms": round(host, 3),
        "untimed_share": round(statistics.median(untimed(s) for s in scans), 4)}))
PY
done
