#!/usr/bin/env bash
# Global localization as a new user runs it, over a matrix of buildings, LiDARs, platforms and seeds:
# simulate a mapping run, build the map from its scans, simulate a separate test run (with walking people the
# map does not hold), `localize --init global` with default parameters and nothing else, `evaluate`.
# Prints one JSON line per run on stdout (and appends it to OUT/results.jsonl), progress on stderr, and a
# summary at the end. Nothing here is tuned to a scene: every run uses the same command line.
#
#   bash bench/localization_matrix.sh [--cli PATH] [--out DIR] [--scenes office,symmetric,warehouse,avz,...]
#        [--lidars vlp16,os0-64] [--platforms ground,handheld,drone] [--seeds 1,2] [--walkers N]
#        [--length M] [--particles N] [--extra 'localize flags'] [--tag NAME] [--reuse]
#
# --reuse keeps the maps and simulated test runs already in OUT (compare builds on the same data); --tag names
# the localization output (OUT/RUN/NAME, default loc) so several builds' results sit side by side.
#
# Scenes: the built-in ones, `avz` (../shared/data/avz/avz_no_roof.stl with a ground slab) or a mesh path.
# Changed maps (issue 16): `office-skip` and `symmetric-skip` map the building with a mapping route that never
# enters the east wing's north rooms, and their test routes end in one of those rooms (the symmetric building's
# skipped room has a mapped twin in the west wing); `warehouse-skip` maps the hall without entering two of its
# aisles (between look-alike racks; the see-through racks let the map hold them) and drives up one of them;
# `avz-skip` maps avz without entering one of the east rooms and ends its test route in it; `office-moved` maps
# with furniture seed 1 and tests in the same office furnished by seed 2 (furniture moved after mapping).
# `two-storey` (issue 16's multi-storey building): the office on two storeys of one plan, furnished alike, joined
# by a staircase; the mapping run covers both storeys, odd seeds' test routes run on the upper storey and even
# seeds' on the lower, and the staircase is the landmark (the one thing that tells the storeys apart).
set -euo pipefail
cd "$(dirname "$0")/.."

cli=build/release/tools/tsdf-mcl
out=out/matrix
scenes=office,symmetric,warehouse,avz
lidars=vlp16,os0-64
platforms=ground,handheld,drone
seeds=1,2
walkers=3
length=40
particles=""
extra=""
tag=loc
reuse=0
while [ $# -gt 0 ]; do
  case "$1" in
    --cli) cli="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --scenes) scenes="$2"; shift 2 ;;
    --lidars) lidars="$2"; shift 2 ;;
    --platforms) platforms="$2"; shift 2 ;;
    --seeds) seeds="$2"; shift 2 ;;
    --walkers) walkers="$2"; shift 2 ;;
    --length) length="$2"; shift 2 ;;
    --particles) particles="$2"; shift 2 ;;
    --extra) extra="$2"; shift 2 ;;
    --tag) tag="$2"; shift 2 ;;
    --reuse) reuse=1; shift ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "localization_matrix.sh: unknown option $1 (--help lists them)" >&2; exit 2 ;;
  esac
done
[ -x "$cli" ] || { echo "localization_matrix.sh: no tsdf-mcl at $cli (build first: cmake --preset release && cmake --build --preset release)" >&2; exit 1; }
mkdir -p "$out"
results="$out/results-$tag.jsonl"
: >"$results"

scene_args() {  # the simulate flags of a scene name
  case "$1" in
    office-skip|office-moved) echo "--scene office" ;;
    symmetric-skip) echo "--scene symmetric" ;;
    warehouse-skip) echo "--scene warehouse" ;;
    office|symmetric|warehouse|two-storey) echo "--scene $1" ;;
    avz|avz-skip)
      local mesh=../shared/data/avz/avz_no_roof.stl
      [ -e "$mesh" ] || { echo "localization_matrix.sh: $mesh is absent (the avz scene needs ../shared/data)" >&2; return 1; }
      echo "--scene $mesh --ground_plane 0" ;;
    *) echo "--scene $1" ;;
  esac
}

mapping_args() {  # extra simulate flags of a scene's mapping run
  case "$1" in
    office-skip) echo "--skip_areas 36,11.7,50,20" ;;
    symmetric-skip) echo "--skip_areas 26,9.4,40,16" ;;
    warehouse-skip) echo "--skip_areas 17.3,7.5,28.3,22.6" ;;
    avz-skip) echo "--skip_areas 1.3,-2.3,9,3.7" ;;
  esac
}
test_args() {  # extra simulate flags of a scene's test runs (scene, seed)
  case "$1" in
    two-storey) echo "--storey $(( $2 % 2 ))" ;;  # odd seeds on the upper storey, even ones on the lower
    office-skip) echo "--start 20,10.2,0 --waypoints 42,10.2;42,15" ;;
    symmetric-skip) echo "--start 12,8,0 --waypoints 29,8;29,12.5" ;;
    warehouse-skip) echo "--start 6,4,0 --waypoints 20,4;20,19" ;;
    avz-skip) echo "--start 0,-12,90 --waypoints 0,0.45;5.5,0.45;5.5,2.5" ;;
    office-moved) echo "--scene_seed 2" ;;
  esac
}

IFS=, read -r -a scene_list <<<"$scenes"
IFS=, read -r -a lidar_list <<<"$lidars"
IFS=, read -r -a platform_list <<<"$platforms"
IFS=, read -r -a seed_list <<<"$seeds"

for scene in "${scene_list[@]}"; do
  sargs=$(scene_args "$scene") || continue
  stag=$(basename "$scene" | tr -c 'A-Za-z0-9_\n-' _)
  for lidar in "${lidar_list[@]}"; do
    map="$out/$stag-$lidar.tsdf"
    if [ ! -e "$map" ]; then
      echo "matrix: mapping $scene with $lidar" >&2
      rm -rf "$out/$stag-$lidar-mapping"
      # shellcheck disable=SC2086
      "$cli" simulate $sargs $(mapping_args "$scene") --lidar "$lidar" --route mapping --seed 1 -o "$out/$stag-$lidar-mapping" >/dev/null 2>"$map.log"
      "$cli" build-map --dataset "$out/$stag-$lidar-mapping" -o "$map" >/dev/null 2>>"$map.log"
      rm -rf "$out/$stag-$lidar-mapping/scans"  # the map is what later runs need
    fi
    for platform in "${platform_list[@]}"; do
      for seed in "${seed_list[@]}"; do
        run="$out/$stag-$lidar-$platform-$seed"
        echo "matrix: $scene $lidar $platform seed $seed" >&2
        if [ "$reuse" = 0 ] || [ ! -e "$run/test/times.txt" ]; then
          rm -rf "$run"
          mkdir -p "$run"
          # shellcheck disable=SC2086
          "$cli" simulate $sargs $(test_args "$scene" "$seed") --lidar "$lidar" --route test --platform "$platform" --seed "$seed" \
            --walkers "$walkers" --length "$length" -o "$run/test" >/dev/null 2>"$run/simulate.log"
        fi
        rm -rf "${run:?}/$tag"
        start=$(date +%s%N)
        # shellcheck disable=SC2086
        "$cli" localize --map "$map" --dataset "$run/test" --init global --seed "$seed" \
          ${particles:+--particles $particles} $extra -o "$run/$tag" 2>"$run/$tag.log" || {
          echo "{\"scene\":\"$stag\",\"lidar\":\"$lidar\",\"platform\":\"$platform\",\"seed\":$seed,\"error\":\"localize failed\"}" | tee -a "$results"
          continue
        }
        seconds=$(( ($(date +%s%N) - start) / 1000000 ))e-3
        "$cli" evaluate --estimate "$run/$tag/trajectory.tum" --dataset "$run/test" >"$run/$tag-metrics.json" 2>>"$run/$tag.log"
        python3 - "$run/$tag-metrics.json" "$stag" "$lidar" "$platform" "$seed" "$seconds" <<'EOF' | tee -a "$results"
import json, sys
m = json.load(open(sys.argv[1]))
after = m.get("after_convergence") or {}
false = m.get("false_convergence") or {}
row = {"scene": sys.argv[2], "lidar": sys.argv[3], "platform": sys.argv[4], "seed": int(sys.argv[5]),
       "localize_s": round(float(sys.argv[6]), 1), "converged": m["converged"],
       "convergence_time_s": (m.get("convergence") or {}).get("time_s"),
       "localized_fraction": round(m["localized_fraction"], 3), "ate_m": after.get("ate_rmse_m"),
       "rotation_rmse_deg": after.get("rotation_rmse_deg"), "claimed_converged_scans": false.get("claimed_converged_scans"),
       "false_claims": false.get("false_claims"), "scans": m["scans"],
       "lost_tracks": (m.get("lost_tracks") or {}).get("episodes")}
# The symmetric building: the scans from the landmark's first sighting on are what a localizer can be judged on
# (before it, which wing is right is a guess); none when the run never sees it.
landmark = m.get("after_landmark")
if landmark is not None:
    row["landmark_seen_scan"] = landmark["first_seen_scan"]
    row["after_landmark_localized"] = None if landmark["localized_fraction"] is None else round(landmark["localized_fraction"], 3)
    row["after_landmark_lost_tracks"] = landmark["lost_tracks"]
print(json.dumps(row))
EOF
      done
    done
  done
done

python3 - "$results" <<'EOF' >&2
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
ok = [r for r in rows if r.get("converged") and not r.get("false_claims")]
false = [r for r in rows if r.get("false_claims")]
print(f"matrix: {len(rows)} runs; {len(ok)} converged right with no false claim; "
      f"{len(false)} with false convergence claims; {len(rows) - len(ok) - len(false)} not localized")
# Issue 16's targets (lost track: > 1 m off for over 2 s after having been localized). Where a run has a landmark,
# over the scans from its first sighting on; a run that never sees it is a guess between mirror images.
judged = [r for r in rows if "error" not in r and r.get("landmark_seen_scan", 0) is not None]
def share(r): return r.get("after_landmark_localized", r.get("localized_fraction"))
def lost(r): return r.get("after_landmark_lost_tracks", r.get("lost_tracks"))
guesses = len([r for r in rows if "landmark_seen_scan" in r and r["landmark_seen_scan"] is None])
unjudged = f" ({guesses} more never see the landmark that tells look-alike places apart)" if guesses else ""
print(f"matrix: over the {len(judged)} runs that can tell where they are{unjudged}: "
      f"{len([r for r in judged if (lost(r) or 0) > 0])} with a lost track, "
      f"{len([r for r in judged if (share(r) or 0) >= 0.95])} at least 95 % localized")
fmt = lambda v, f: "-" if v is None else format(v, f)
for r in rows:
    landmark = ""
    if "landmark_seen_scan" in r:
        landmark = ("; never sees the landmark" if r["landmark_seen_scan"] is None else
                    f"; from the landmark on localized {fmt(r.get('after_landmark_localized'), '.2f')}, "
                    f"lost tracks {r.get('after_landmark_lost_tracks')}")
    print(f"  {r['scene']:10s} {r['lidar']:7s} {r['platform']:9s} seed {r['seed']}: "
          f"{'converged' if r.get('converged') else 'NOT converged'} at {fmt(r.get('convergence_time_s'), '.1f')} s, "
          f"localized {fmt(r.get('localized_fraction'), '.2f')}, ATE {fmt(r.get('ate_m'), '.3f')} m, "
          f"false claims {r.get('false_claims')} of {r.get('claimed_converged_scans')}, "
          f"lost tracks {r.get('lost_tracks')}{landmark}, {r.get('localize_s')} s")
EOF
