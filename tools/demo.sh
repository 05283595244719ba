#!/usr/bin/env bash
# The main job, from a fresh Debian 12 machine: install, build, simulate the built-in office (a mapping run and
# a separate test run), build the TSDF map from the mapping scans, localize globally on the test run (no initial
# guess), evaluate against ground truth and draw the pictures. Everything lands in demo-out/.
#
#   bash tools/demo.sh [--particles N] [--backend auto|vulkan|cpu] [--seed N] [--lidar vlp16|os0-64]
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=build_env.sh
source tools/build_env.sh  # the build the test command reuses

particles=50000
backend=auto
seed=1
lidar=vlp16
while [ $# -gt 0 ]; do
  case "$1" in
    --particles) particles="$2"; shift 2 ;;
    --backend) backend="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    --lidar) lidar="$2"; shift 2 ;;
    *) echo "demo.sh: unknown option $1 (--particles N --backend auto|vulkan|cpu --seed N --lidar vlp16|os0-64)" >&2; exit 2 ;;
  esac
done

step() { printf '==> %s\n' "$*" >&2; }

step "1/7 installing Debian packages (if missing)"
bash tools/setup.sh
step "2/7 building (Release)"
build_preset release
cli=build/release/tools/tsdf-mcl
out=demo-out
# A rerun starts over: the simulator refuses to write scans into a dataset that exists. Only what this script
# writes is removed.
if [ -e "$out/mapping" ] || [ -e "$out/test" ] || [ -e "$out/run" ]; then
  echo "demo.sh: replacing the previous run's results in $out/" >&2
  rm -rf "$out/mapping" "$out/test" "$out/run" "$out/office.tsdf" "$out"/*.png "$out"/*.log "$out/metrics.json"
fi
mkdir -p "$out"

step "3/7 simulating the office: mapping run and test run ($lidar)"
"$cli" simulate --scene office --lidar "$lidar" --route mapping --seed "$seed" -o "$out/mapping"
"$cli" simulate --scene office --lidar "$lidar" --route test --seed "$seed" -o "$out/test"

step "4/7 building the TSDF map from the mapping scans"
"$cli" build-map --dataset "$out/mapping" -o "$out/office.tsdf"
"$cli" info "$out/office.tsdf"

step "5/7 global localization on the test run ($particles particles, backend $backend)"
# Global, with no initial guess and no priors: the up direction and the sensor's height come from the first
# scan (docs/filter.md). Particle snapshots every 10 scans for the picture below.
"$cli" localize --map "$out/office.tsdf" --dataset "$out/test" --init global --particles "$particles" \
  --snapshot_every 10 --backend "$backend" --seed "$seed" --overwrite -o "$out/run" 2> >(tee "$out/localize.log" >&2)

step "6/7 evaluating against ground truth"
"$cli" evaluate --estimate "$out/run/trajectory.tum" --dataset "$out/test" --plot "$out/translation_error.png" \
  > "$out/metrics.json" 2> >(tee "$out/evaluate.log" >&2)

step "7/7 drawing pictures"
"$cli" render --map "$out/office.tsdf" --ground_truth "$out/test" --estimate "$out/run/trajectory.tum" \
  --title "office: true and estimated trajectory" -o "$out/trajectory.png"
# The cloud at the start, in the multimodal phase and after convergence (the paper's Fig. 1 / Fig. 5).
snaps="$out/run/snapshots"
panels=() captions=()
for s in init:start scan_000000:"after the first scan" scan_000010:"scan 10" scan_000040:"scan 40" scan_000400:"scan 400"; do
  f="$snaps/${s%%:*}.bin"
  [ -e "$f" ] && panels+=("$f") && captions+=("${s#*:}")
done
if [ ${#panels[@]} -gt 0 ]; then
  "$cli" render --map "$out/office.tsdf" --particles "$(IFS=,; echo "${panels[*]}")" \
    --captions "$(IFS=,; echo "${captions[*]}")" -o "$out/particles.png"
fi

sleep 0.2  # let the tee'd logs flush
step "result"
tail -n 1 "$out/localize.log" >&2
tail -n 3 "$out/evaluate.log" >&2
echo "metrics:  $out/metrics.json   per-scan report: $out/run/report.json" >&2
echo "pictures: $out/trajectory.png $out/particles.png $out/translation_error.png" >&2
