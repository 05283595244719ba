#!/usr/bin/env bash
# Localization in the open air and at scale (issue 51, target 2): the built-in town (docs/simulator.md) at several
# sizes, its map built from the mesh (build-map --mesh scene.ply) and from a mapping run's scans, test runs localized
# from the true first pose (--init x,y,z,roll,pitch,yaw from poses.txt) and globally (--init global), with default
# parameters otherwise. Prints one JSON line per map on stdout (kind "map": memory against the town's and the
# streets' area, build time) and one per localization run (kind "run": localized share, ATE, share of scans flagged
# converged, time to the first right estimate, update times), appends them to OUT/results-TAG.jsonl, progress on
# stderr, and a summary at the end.
#
#   bash bench/outdoor.sh [--cli PATH] [--out DIR] [--sizes 120,300] [--lidars os0-64,vlp16] [--seeds 1]
#        [--maps mesh,scans] [--inits known,global] [--scene_seed N] [--length M] [--walkers N] [--voxel M]
#        [--scan_spacing M] [--max_memory MIB] [--extra 'localize flags'] [--tag NAME] [--reuse]
#
# A map from scans needs a mapping run over every street (one scan per --scan_spacing m driven, default 1): about
# 1.2 km of route at 120 m, 7 km at 300 m (docs/simulator.md says what it costs); --maps mesh leaves it out.
# --reuse keeps the maps and simulated test runs already in OUT (compare builds on the same data) and, for a map not
# built yet, a mapping run whose scans are still there; --tag names the localization output (OUT/RUN/TAG-MAP-INIT).
#
# Fields read from evaluate's output that older builds lack (flag_stability) are null there.
set -euo pipefail
cd "$(dirname "$0")/.."

cli=build/release/tools/tsdf-mcl
out=out/outdoor
sizes=120,300
lidars=os0-64,vlp16
seeds=1
maps=mesh,scans
inits=known,global
scene_seed=1
length=60
walkers=0
voxel=0.1
scan_spacing=1
max_memory=8192
extra=""
tag=loc
reuse=0
while [ $# -gt 0 ]; do
  case "$1" in
    --cli) cli="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --sizes) sizes="$2"; shift 2 ;;
    --lidars) lidars="$2"; shift 2 ;;
    --seeds) seeds="$2"; shift 2 ;;
    --maps) maps="$2"; shift 2 ;;
    --inits) inits="$2"; shift 2 ;;
    --scene_seed) scene_seed="$2"; shift 2 ;;
    --length) length="$2"; shift 2 ;;
    --walkers) walkers="$2"; shift 2 ;;
    --voxel) voxel="$2"; shift 2 ;;
    --scan_spacing) scan_spacing="$2"; shift 2 ;;
    --max_memory) max_memory="$2"; shift 2 ;;
    --extra) extra="$2"; shift 2 ;;
    --tag) tag="$2"; shift 2 ;;
    --reuse) reuse=1; shift ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "outdoor.sh: unknown option $1 (--help lists them)" >&2; exit 2 ;;
  esac
done
[ -x "$cli" ] || { echo "outdoor.sh: no tsdf-mcl at $cli (build first: cmake --preset release && cmake --build --preset release)" >&2; exit 1; }
mkdir -p "$out"
results="$out/results-$tag.jsonl"
: >"$results"

now_ms() { echo $(( $(date +%s%N) / 1000000 )); }

# The map's line: memory (tsdf-mcl info --json) against the town's area and the streets' (the traversable floor of
# the run that gave the scene), and how long it took to build.
map_line() {  # map size lidar source build_ms simulation.json simulate_ms
  "$cli" info "$1" --json >"$1.info.json"
  python3 - "$1.info.json" "$2" "$3" "$4" "$5" "$6" "$7" <<'EOF' | tee -a "$results"
import json, sys
info = json.load(open(sys.argv[1]))
size, lidar, source, build_ms = float(sys.argv[2]), sys.argv[3], sys.argv[4], int(sys.argv[5])
sim, simulate_ms = json.load(open(sys.argv[6])), int(sys.argv[7])
mib = info["memory_bytes"] / 2**20
row = {"kind": "map", "size_m": size, "lidar": lidar if source == "scans" else None, "source": source,
       "town_area_m2": size * size, "street_area_m2": round(sim["scene"]["traversable_area_m2"]),
       "triangles": sim["scene"]["triangles"], "voxel_m": info["voxel_size"], "memory_mib": round(mib, 1),
       "mib_per_hectare": round(mib / (size * size) * 1e4, 2), "allocated_blocks": info.get("allocated_blocks"),
       "known_voxels": info.get("known_voxels"), "build_s": round(build_ms / 1000, 1)}
if source == "scans":  # the mapping run
    row.update({"mapping_route_m": round(sim["route"]["length_m"]), "mapping_scans": sim["counts"]["scans"],
                "mapping_simulate_s": round(simulate_ms / 1000, 1) if simulate_ms >= 0 else None})
print(json.dumps(row))
EOF
}

# The true first pose of a dataset as x,y,z,roll,pitch,yaw (m, rad) from its poses.txt.
first_pose() {
  python3 - "$1/poses.txt" <<'EOF'
import math, sys
r = [float(v) for v in open(sys.argv[1]).readline().split()]
R = [r[0:3], r[4:7], r[8:11]]
roll, pitch, yaw = math.atan2(R[2][1], R[2][2]), -math.asin(max(-1, min(1, R[2][0]))), math.atan2(R[1][0], R[0][0])
print(",".join(f"{v:.6f}" for v in (r[3], r[7], r[11], roll, pitch, yaw)))
EOF
}

# One run's line from evaluate's metrics and localize's report.json.
run_line() {  # metrics report size lidar seed map init localize_ms
  python3 - "$@" <<'EOF' | tee -a "$results"
import json, statistics, sys
m, report = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
size, lidar, seed, source, init, ms = float(sys.argv[3]), sys.argv[4], int(sys.argv[5]), sys.argv[6], sys.argv[7], int(sys.argv[8])
scans = report["scans"]
after = m.get("after_convergence") or {}
false = m.get("false_convergence") or {}
stability = m.get("flag_stability") or {}  # evaluate prints it from the filter redesign on (issue 51)
summary = report.get("summary") or {}
# A global update: the filter's updates while the global search's particles (more than 5,000) are still alive.
wide = [s["timings_ms"]["update_total"] for s in scans if s.get("updated") and s.get("particles", 0) > 5000]
if init != "global":
    wide = []
rnd = lambda v, d: None if v is None else round(v, d)
print(json.dumps({
    "kind": "run", "size_m": size, "lidar": lidar, "seed": seed, "map": source, "init": init, "scans": len(scans),
    "localized_fraction": rnd(m.get("localized_fraction"), 3), "ate_m": rnd(after.get("ate_rmse_m"), 3),
    "converged_share": round(sum(1 for s in scans if s.get("converged")) / max(1, len(scans)), 3),
    "first_right_s": rnd((m.get("localized_from") or {}).get("time_s"), 1),
    "first_converged_scan": summary.get("first_converged_scan"),
    "false_claims": false.get("false_claims"), "lost_tracks": (m.get("lost_tracks") or {}).get("episodes"),
    "right_flagged_share": rnd(stability.get("right_flagged_share"), 3),
    "flag_changes_per_minute": rnd(stability.get("flag_changes_per_minute"), 2),
    "lost_while_right": stability.get("lost_while_right"),
    "states": summary.get("scans_by_state"),
    "update_ms_median": rnd((summary.get("update_ms") or {}).get("median"), 2),
    "global_updates": len(wide), "global_update_ms_median": rnd(statistics.median(wide), 1) if wide else None,
    "initialization_ms": rnd((report.get("initialization") or {}).get("ms"), 1) if init == "global" else None,
    "localize_s": round(ms / 1000, 1)}))
EOF
}

IFS=, read -r -a size_list <<<"$sizes"
IFS=, read -r -a lidar_list <<<"$lidars"
IFS=, read -r -a seed_list <<<"$seeds"
IFS=, read -r -a map_list <<<"$maps"
IFS=, read -r -a init_list <<<"$inits"
wants() { case ",$1," in *",$2,"*) return 0 ;; esac; return 1; }

for size in "${size_list[@]}"; do
  town=(--scene town --scene_size "$size" --scene_seed "$scene_seed")
  base="$out/town$size-s$scene_seed"
  mkdir -p "$base"
  # The mesh map: the scene as any run of the town writes it (a 1 m run is enough).
  if wants "$maps" mesh && { [ "$reuse" = 0 ] || [ ! -e "$base/mesh.tsdf" ]; }; then
    echo "outdoor: $size m town, map from its mesh" >&2
    rm -rf "$base/scene"
    "$cli" simulate "${town[@]}" --route test --length 1 -o "$base/scene" >/dev/null 2>"$base/scene.log"
    rm -rf "$base/scene/scans"
    start=$(now_ms)
    "$cli" build-map --mesh "$base/scene/scene.ply" --voxel "$voxel" --max_memory "$max_memory" -o "$base/mesh.tsdf" \
      >/dev/null 2>"$base/mesh.log"
    map_line "$base/mesh.tsdf" "$size" - mesh $(( $(now_ms) - start )) "$base/scene/simulation.json" 0
  fi
  for lidar in "${lidar_list[@]}"; do
    if wants "$maps" scans && { [ "$reuse" = 0 ] || [ ! -e "$base/scans-$lidar.tsdf" ]; }; then
      simulate_ms=-1  # a mapping run kept from before
      if [ "$reuse" = 0 ] || [ ! -e "$base/mapping-$lidar/times.txt" ]; then
        echo "outdoor: $size m town, mapping run with $lidar" >&2
        rm -rf "$base/mapping-$lidar"
        start=$(now_ms)
        "$cli" simulate "${town[@]}" --lidar "$lidar" --route mapping --seed 1 --scan_spacing "$scan_spacing" \
          -o "$base/mapping-$lidar" >/dev/null 2>"$base/mapping-$lidar.log"
        simulate_ms=$(( $(now_ms) - start ))
      fi
      echo "outdoor: building the map from the mapping run's scans" >&2
      start=$(now_ms)
      "$cli" build-map --dataset "$base/mapping-$lidar" --voxel "$voxel" --max_memory "$max_memory" \
        -o "$base/scans-$lidar.tsdf" >/dev/null 2>>"$base/mapping-$lidar.log"
      map_line "$base/scans-$lidar.tsdf" "$size" "$lidar" scans $(( $(now_ms) - start )) \
        "$base/mapping-$lidar/simulation.json" "$simulate_ms"
      rm -rf "$base/mapping-$lidar/scans"  # the map is what later runs need
    fi
    for seed in "${seed_list[@]}"; do
      run="$base/$lidar-$seed"
      if [ "$reuse" = 0 ] || [ ! -e "$run/test/times.txt" ]; then
        echo "outdoor: $size m town, $lidar test run, seed $seed" >&2
        rm -rf "$run"
        mkdir -p "$run"
        "$cli" simulate "${town[@]}" --lidar "$lidar" --route test --seed "$seed" --length "$length" \
          --walkers "$walkers" -o "$run/test" >/dev/null 2>"$run/simulate.log"
      fi
      for source in "${map_list[@]}"; do
        map="$base/$([ "$source" = mesh ] && echo mesh || echo "scans-$lidar").tsdf"
        [ -e "$map" ] || { echo "outdoor: no map $map" >&2; continue; }
        for init in "${init_list[@]}"; do
          mode=global
          [ "$init" = known ] && mode=$(first_pose "$run/test")
          loc="$run/$tag-$source-$init"
          echo "outdoor: $size m, $lidar seed $seed, map from $source, init $init" >&2
          rm -rf "$loc"
          start=$(now_ms)
          # shellcheck disable=SC2086
          "$cli" localize --map "$map" --dataset "$run/test" --init "$mode" --seed "$seed" $extra -o "$loc" \
            >/dev/null 2>"$loc.log" || {
            echo "{\"kind\":\"run\",\"size_m\":$size,\"lidar\":\"$lidar\",\"seed\":$seed,\"map\":\"$source\",\"init\":\"$init\",\"error\":\"localize failed\"}" | tee -a "$results"
            continue
          }
          elapsed=$(( $(now_ms) - start ))
          "$cli" evaluate --estimate "$loc/trajectory.tum" --dataset "$run/test" >"$loc-metrics.json" 2>>"$loc.log"
          run_line "$loc-metrics.json" "$loc/report.json" "$size" "$lidar" "$seed" "$source" "$init" "$elapsed"
        done
      done
    done
  done
done

python3 - "$results" <<'EOF' >&2
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
fmt = lambda v, f: "-" if v is None else format(v, f)
for r in rows:
    if r["kind"] == "map":
        print(f"  map {r['size_m']:.0f} m from {r['source']}{' (' + r['lidar'] + ')' if r['lidar'] else ''}: "
              f"{r['memory_mib']} MiB ({r['mib_per_hectare']} MiB per hectare of town; streets "
              f"{r['street_area_m2']} m^2), built in {r['build_s']} s"
              + (f" from a {r['mapping_route_m']} m mapping run of {r['mapping_scans']} scans simulated in "
                 f"{r['mapping_simulate_s']} s" if r["source"] == "scans" else ""))
    elif "error" in r:
        print(f"  {r['size_m']:.0f} m {r['lidar']} seed {r['seed']} {r['map']} {r['init']}: {r['error']}")
    else:
        print(f"  {r['size_m']:.0f} m {r['lidar']:6s} seed {r['seed']} map {r['map']:5s} init {r['init']:6s}: "
              f"localized {fmt(r['localized_fraction'], '.2f')} from {fmt(r['first_right_s'], '.1f')} s, "
              f"ATE {fmt(r['ate_m'], '.3f')} m, flagged converged {fmt(r['converged_share'], '.2f')}, "
              f"false claims {r['false_claims']}, update {fmt(r['update_ms_median'], '.1f')} ms median"
              f"{', global update ' + fmt(r['global_update_ms_median'], '.0f') + ' ms' if r['global_updates'] else ''}, "
              f"{r['localize_s']} s")
EOF
