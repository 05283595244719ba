#!/usr/bin/env bash
# Soak test: localize over a long looped dataset (every scan a filter update) on each backend, the Vulkan one with
# the validation layer on. Reports the resident memory (RSS) once the run has settled (after 2 % of the scans) and at
# its end, and fails if it grew by more than 16 MiB or the validation layer said anything (it reports every Vulkan
# object still alive when the device is destroyed, so descriptor and memory leaks show there).
#
#   bash tools/soak.sh [UPDATES] [BACKENDS]     default: 10000 cpu,vulkan; needs a release build
set -euo pipefail
cd "$(dirname "$0")/.."
updates=${1:-10000}
backends=${2:-cpu,vulkan}
cli=build/release/tools/tsdf-mcl
work=build/soak
[ -x "$cli" ] || { echo "soak.sh: build first (cmake --preset release && cmake --build --preset release)" >&2; exit 1; }

if [ ! -f "$work/office.tsdf" ]; then
  rm -rf "$work" && mkdir -p "$work"
  "$cli" simulate --scene office --route mapping --seed 1 -o "$work/mapping" 2>/dev/null
  "$cli" build-map --dataset "$work/mapping" -o "$work/office.tsdf" 2>/dev/null
  "$cli" simulate --scene office --route test --seed 1 --length 15 -o "$work/route" 2>/dev/null
fi

# The route over and over: scans linked, timestamps continued, poses and odometry repeated (the jump back to the
# start of the route is one large motion for the filter).
looped=$work/looped-$updates
if [ ! -f "$looped/times.txt" ]; then
  rm -rf "$looped" && mkdir -p "$looped/scans"
  scans=("$work/route/scans"/*.bin)
  n=${#scans[@]}
  span=$(awk 'NR==1{a=$1} {b=$1} END{printf "%.9f", b - a + 0.1}' "$work/route/times.txt")
  for ((k = 0; k < updates; ++k)); do
    ln -s "$(realpath "${scans[k % n]}")" "$looped/scans/$(printf %06d "$k").bin"
  done
  for f in times.txt poses.txt odom.txt; do : >"$looped/$f"; done
  for ((c = 0; c * n < updates; ++c)); do
    awk -v c="$c" -v span="$span" '{printf "%.9f\n", $1 + c * span}' "$work/route/times.txt" >>"$looped/times.txt"
    cat "$work/route/poses.txt" >>"$looped/poses.txt"
    cat "$work/route/odom.txt" >>"$looped/odom.txt"
  done
  for f in times.txt poses.txt odom.txt; do head -n "$updates" "$looped/$f" >"$looped/$f.cut" && mv "$looped/$f.cut" "$looped/$f"; done
fi

rss_kib() { awk '/^VmRSS:/{print $2}' "/proc/$1/status" 2>/dev/null || echo 0; }
status=0
for backend in ${backends//,/ }; do
  log=$work/soak-$backend.log
  TSDF_MCL_VALIDATION=1 "$cli" localize --map "$work/office.tsdf" --dataset "$looped" --backend "$backend" \
    --init_max_tilt 0.3 --init_height_band 0.3,0.7 --particles 2000 --min_particles 2000 --max_particles 2000 \
    --max_beams 256 --update_min_d 0 --update_min_a 0 -o "$work/run-$backend" 2>"$log" &
  pid=$!
  settled=$((updates / 50)) start_rss="" end_rss=0 start_scan=0
  started=$(date +%s)
  while kill -0 "$pid" 2>/dev/null; do
    rss=$(rss_kib "$pid")
    scan=$(tail -c 300 "$log" | grep -o '^\[[0-9]*/' | tail -1 | tr -d '[/' || true)
    if [ -z "$start_rss" ] && [ "${scan:-0}" -ge "$settled" ]; then start_rss=$rss start_scan=$scan; fi
    [ "$rss" -gt 0 ] && end_rss=$rss
    sleep 0.5
  done
  rc=0
  wait "$pid" || rc=$?
  seconds=$(($(date +%s) - started))
  made=$(grep -c '^\[' "$log" || true)
  validation=$(grep -c 'vulkan validation' "$log" || true)
  growth=$(( (end_rss - ${start_rss:-0}) / 1024 ))
  echo "soak.sh: $backend: exit $rc, $made scans in $seconds s, RSS $(( ${start_rss:-0} / 1024 )) MiB at scan" \
       "$start_scan, $((end_rss / 1024)) MiB at the end (growth $growth MiB), $validation validation messages"
  grep -o '[0-9]* filter updates' "$log" | sed "s/^/soak.sh: $backend: /" || true
  if [ "$rc" -ne 0 ] || [ "$validation" -ne 0 ] || [ -z "$start_rss" ] || [ "$growth" -gt 16 ]; then
    echo "soak.sh: $backend FAILED (see $log)" >&2
    status=1
  fi
done
exit $status
