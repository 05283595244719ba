#!/usr/bin/env bash
# Cross-builds tsdf-mcl for aarch64 (cmake --preset arm64) and runs a subset of the test suite under qemu-aarch64
# with the arm64 lavapipe and the Vulkan validation layers on (a validation message fails a test), then the arm64
# CLI itself (--help, a tiny bench on lavapipe and on the CPU's NEON path), then builds the arm64 Debian packages and
# checks that apt resolves their Depends. Needs tools/setup.sh --arm64.
#
# The subset (TSDF_MCL_ARM64_FILTER overrides it) and why: qemu-user runs aarch64 code 10-40x slower than native
# and lavapipe's JIT'd shaders on top of that, so the whole suite (minutes natively) would take an hour. It keeps
# what can break differently on aarch64: the NEON path against the scalar one and the CPU evaluator against its
# double reference (float rounding, FMA contraction), the Vulkan evaluator and reduction against the CPU on arm64
# lavapipe (GPU-vs-CPU agreement, the SPIR-V built by the host's glslc), the map's layout and file format
# (endianness, struct packing), and the filter's unit tests (resampling, KLD, motion, pose estimate). Left out:
# the tests that start the tsdf-mcl program as a child process (Cli*, Sim*Cli, RenderCli, EndToEnd, RealData:
# under qemu-user a child aarch64 process needs binfmt_misc, which containers rarely have; this script runs the
# CLI itself instead) and the long localization runs (GlobalLocalization, Kidnapping, Tracking, ...: minutes each
# under emulation, the same code the unit tests cover).
#
# Usage: tools/test_arm64.sh [--no-build]. Build output: build/arm64. Prints its wall time.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
sysroot=${TSDF_MCL_ARM64_SYSROOT:-/opt/tsdf-mcl/arm64-sysroot}
qemu=$(command -v qemu-aarch64 || true)
if [ -z "$qemu" ] || ! command -v aarch64-linux-gnu-g++ >/dev/null || [ ! -f "$sysroot/.tsdf-mcl-packages" ]; then
  echo "test_arm64.sh: the aarch64 cross compiler, qemu-aarch64 or the sysroot $sysroot is missing:" \
    "run tools/setup.sh --arm64" >&2
  exit 1
fi
export TSDF_MCL_ARM64_SYSROOT=$sysroot

if [ "${1:-}" != "--no-build" ]; then
  if command -v ccache >/dev/null; then
    export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD} CMAKE_CXX_COMPILER_LAUNCHER=ccache CMAKE_C_COMPILER_LAUNCHER=ccache
  fi
  # Compile only the test sources of the subset (set TSDF_MCL_ARM64_FILTER and TSDF_MCL_ARM64_SOURCES together).
  sources=${TSDF_MCL_ARM64_SOURCES:-'/test_(cpu_evaluator|vulkan_evaluator|weight_reduction|filter_(subset_first|motion|resampling|kld|pose_estimate)|tsdf_map|map_file|scan_preprocessing|pointcloud2|transform_tree)\.cpp$'}
  cmake --preset arm64 -DTSDF_MCL_TEST_SOURCES_REGEX="$sources" >/dev/null
  nice -n 10 cmake --build --preset arm64 --target tsdf_mcl_tests tsdf-mcl
fi
tests=build/arm64/tests/tsdf_mcl_tests
cli=build/arm64/tools/tsdf-mcl
for f in "$tests" "$cli" "$cli-bench"; do
  grep -q "ARM aarch64" <<<"$(file -L "$f")" || { echo "test_arm64.sh: $f is not an aarch64 binary" >&2; exit 1; }
done

# The arm64 lavapipe and validation layer from the sysroot; their JSON's library paths (/usr/lib/aarch64-linux-gnu/...)
# resolve inside it because qemu -L looks there first.
export VK_ICD_FILENAMES=$sysroot/usr/share/vulkan/icd.d/lvp_icd.aarch64.json
export VK_DRIVER_FILES=$VK_ICD_FILENAMES
export VK_LAYER_PATH=$sysroot/usr/share/vulkan/explicit_layer.d
export TSDF_MCL_VALIDATION=1 LP_NUM_THREADS=2 QEMU_LD_PREFIX=$sysroot
run() { timeout 900 "$qemu" -L "$sysroot" "$@"; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

filter=${TSDF_MCL_ARM64_FILTER:-'CpuEvaluator*:NeonKernel*:VulkanEvaluator.*:VulkanVsCpu*:VulkanReduction*:WeightReduction.*:SubsetFirst.*:*/SubsetFirstPasses.*:TsdfMap.*:MapFile.*:MotionModel.*:Resampling.*:KldSampling.*:PoseEstimator.*:RotationAveraging.*:ScanPreprocessing.*:PointCloud2.*:TransformTree.*'}
echo "test_arm64.sh: $tests --gtest_filter='$filter' under qemu-aarch64"
run "$tests" --gtest_filter="$filter" --gtest_brief=1
# The aarch64 evaluator must have taken the NEON path, not silently the scalar one.
run "$tests" --gtest_filter='CpuEvaluator.NeonPathEqualsScalarPath' >"$work/neon.log" 2>&1 || true
grep -q '^\[       OK \] CpuEvaluator.NeonPathEqualsScalarPath' "$work/neon.log" ||
  { cat "$work/neon.log" >&2; echo "test_arm64.sh: CpuEvaluator.NeonPathEqualsScalarPath did not pass (skipped?)" >&2; exit 1; }

echo "test_arm64.sh: the arm64 CLI"
run "$cli" --help >"$work/help.txt"
grep -q '^  bench' "$work/help.txt" || { echo "test_arm64.sh: tsdf-mcl --help lists no bench command" >&2; exit 1; }
# A tiny map and bench made and run by the arm64 programs: the Vulkan backend on the arm64 lavapipe (validation on)
# and the CPU backend, which must name its NEON path. The benchmark program is run itself: `tsdf-mcl bench` starts
# it in its place, which qemu-user cannot without binfmt_misc.
run "$cli" simulate --scene office --route test --length 0.3 --start 5,5,0 -o "$work/route" >"$work/sim.log" 2>&1 ||
  { cat "$work/sim.log" >&2; echo "test_arm64.sh: simulate failed under qemu" >&2; exit 1; }
run "$cli" build-map --mesh "$work/route/scene.ply" --voxel 0.2 -o "$work/office.tsdf" >"$work/map.log" 2>&1 ||
  { cat "$work/map.log" >&2; echo "test_arm64.sh: build-map failed under qemu" >&2; exit 1; }
run "$cli-bench" --map "$work/office.tsdf" --dataset "$work/route" --particles 256 --points 64 --backend vulkan,cpu \
  --repetitions 1 --warmup 1 >"$work/bench.json" 2>"$work/bench.log" ||
  { cat "$work/bench.log" >&2; echo "test_arm64.sh: bench failed under qemu" >&2; exit 1; }
grep -q '"backend":"vulkan","device":"llvmpipe' "$work/bench.json" &&
  grep -q '"backend":"cpu","device":"CPU ([0-9]* threads, NEON)"' "$work/bench.json" ||
  { cat "$work/bench.json" >&2; echo "test_arm64.sh: bench did not run on arm64 lavapipe and the NEON path" >&2; exit 1; }
# The arm64 Debian packages: built for arm64 with an aarch64 program, and apt resolves their Depends from Debian's
# arm64 archive (the host has arm64 as a dpkg architecture; --simulate installs nothing).
(cd build/arm64 && cpack -G DEB -B "$work/pkgs" >"$work/cpack.log" 2>&1) ||
  { cat "$work/cpack.log" >&2; echo "test_arm64.sh: cpack failed" >&2; exit 1; }
for name in tsdf-mcl libtsdf-mcl-dev; do
  deb=$(ls "$work"/pkgs/"$name"_*_arm64.deb 2>/dev/null) || { echo "test_arm64.sh: no ${name}_*_arm64.deb" >&2; exit 1; }
  apt-get install --simulate -qq "$deb" >"$work/apt-$name.log" 2>&1 ||
    { cat "$work/apt-$name.log" >&2; echo "test_arm64.sh: apt cannot resolve the Depends of $deb" >&2; exit 1; }
done
dpkg-deb -x "$work"/pkgs/tsdf-mcl_*_arm64.deb "$work/root"
grep -q "ARM aarch64" <<<"$(file "$work/root/usr/bin/tsdf-mcl")" || { echo "test_arm64.sh: the arm64 package's program is not aarch64" >&2; exit 1; }
echo "test_arm64.sh: passed in $(($(date +%s) - start)) s"
