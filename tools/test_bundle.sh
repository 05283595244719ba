#!/usr/bin/env bash
# Checks tools/bundle.sh's folder on this machine with lavapipe standing in for the GPU driver: in an emptied
# environment, the bundle's tsdf-mcl loads the bundled Vulkan loader, points it at an "NVIDIA" ICD found in the
# ICD folders (here a copy of lavapipe's manifest named nvidia_icd.json) and runs `bench` on the vulkan backend;
# with no NVIDIA ICD it says so and the loader finds the machine's drivers by itself.
# Usage: tools/test_bundle.sh BUILD_DIR [WORK_DIR]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=$(realpath "${1:?usage: test_bundle.sh BUILD_DIR [WORK_DIR]}")
work=${2:-$(mktemp -d)}
rm -rf "$work" && mkdir -p "$work"
work=$(realpath "$work")
fail() { echo "test_bundle.sh: $*" >&2; exit 1; }
lavapipe=$(ls /usr/share/vulkan/icd.d/lvp_icd*.json 2>/dev/null | head -n 1)
[ -n "$lavapipe" ] || fail "lavapipe (mesa-vulkan-drivers) is not installed"

bash "$here/bundle.sh" "$build" "$work/bundle" >"$work/bundle.log" || { cat "$work/bundle.log" >&2; fail "bundle.sh failed"; }
b="$work/bundle"
clean=(env -i HOME="$work" PATH=/usr/bin:/bin LP_NUM_THREADS=2)

# The bundled libraries, not the machine's, serve the program.
"${clean[@]}" LD_DEBUG=libs "$b/tsdf-mcl" --help >"$work/help.txt" 2>"$work/ld.log" || fail "the bundle's tsdf-mcl --help failed"
grep -q '^  bench' "$work/help.txt" || fail "the bundle's tsdf-mcl --help lists no bench command"
grep -q "calling init: $b/lib/libvulkan.so.1" "$work/ld.log" || fail "the Vulkan loader did not come from $b/lib"

# A tiny map and dataset, made by the bundle itself.
"${clean[@]}" "$b/tsdf-mcl" simulate --scene office --route test --length 1 --start 5,5,0 -o "$work/route" \
  >"$work/sim.log" 2>&1 || { cat "$work/sim.log" >&2; fail "simulate failed"; }
"${clean[@]}" "$b/tsdf-mcl" build-map --mesh "$work/route/scene.ply" --voxel 0.1 -o "$work/office.tsdf" \
  >"$work/map.log" 2>&1 || { cat "$work/map.log" >&2; fail "build-map failed"; }
bench=(bench --map "$work/office.tsdf" --dataset "$work/route" --particles 2000 --points 64 --backend vulkan
  --repetitions 1 --warmup 1)

# An "NVIDIA" ICD in one of the searched folders: the script must export it to the loader.
mkdir -p "$work/icd.d"
cp "$lavapipe" "$work/icd.d/nvidia_icd.json"  # Debian's manifest names its library by absolute path
"${clean[@]}" TSDF_MCL_ICD_DIRS="/nonexistent $work/icd.d" "$b/tsdf-mcl" "${bench[@]}" \
  >"$work/bench.json" 2>"$work/bench.log" || { cat "$work/bench.log" >&2; fail "bench through the NVIDIA ICD path failed"; }
grep -q '"backend":"vulkan","device":"llvmpipe' "$work/bench.json" ||
  { cat "$work/bench.json" "$work/bench.log" >&2; fail "bench did not run on the Vulkan device from the ICD"; }
grep -q 'no NVIDIA Vulkan ICD' "$work/bench.log" && fail "the script missed $work/icd.d/nvidia_icd.json"

# No NVIDIA ICD anywhere: one line says so, and the loader's own search (lavapipe here) still serves bench.
"${clean[@]}" TSDF_MCL_ICD_DIRS=/nonexistent "$b/tsdf-mcl" "${bench[@]}" >"$work/bench2.json" 2>"$work/bench2.log" ||
  { cat "$work/bench2.log" >&2; fail "bench without an NVIDIA ICD failed"; }
grep -q 'no NVIDIA Vulkan ICD found' "$work/bench2.log" || fail "no message about the missing NVIDIA ICD"
grep -q '"backend":"vulkan"' "$work/bench2.json" || fail "bench without an NVIDIA ICD printed no vulkan line"
sh -n "$b/run_bench.sh" || fail "run_bench.sh does not parse"
echo "test_bundle.sh: $(tail -n 1 "$work/bundle.log" | sed 's/^bundle.sh: //'); bench ran on $(sed -n 's/.*"device":"\([^"]*\)".*/\1/p' "$work/bench.json")"
