#!/usr/bin/env bash
# The test command, in named steps (a step added later, e.g. an arm64 run, goes into STEPS below).
#
#   bash tools/test.sh          install what is missing, check the format, build (Release, preset `release`: the
#                               build the demo made is reused) and run the whole suite, ROS node included, on
#                               lavapipe with the Vulkan validation layers on.
#   bash tools/test.sh --full   CI (.ci/run): the suite built with warnings as errors (preset `ci`); the arm64 cross
#                               build's subset under qemu-aarch64 (tools/test_arm64.sh, docs/deploy.md); the suite
#                               built with clang, ASan and UBSan (any finding fails the run); every fuzzer for a
#                               short, bounded time (TSDF_MCL_FUZZ_SECONDS, default 20).
# The build is configured as tools/demo.sh configures it (tools/build_env.sh: compilers through ccache where setup.sh
# installed it), so that after the demo only what changed is built.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=build_env.sh
source tools/build_env.sh

full=0
case "${1:-}" in
  "") ;;
  --full) full=1 ;;
  *) echo "test.sh: unknown option $1 (bash tools/test.sh [--full])" >&2; exit 2 ;;
esac
jobs="$(nproc)"
preset=release
[ "$full" = 1 ] && preset=ci

step() { printf '\n==> test.sh: %s (%s)\n' "$1" "$(date -u +%H:%M:%S)" >&2; }

step_setup() { bash tools/setup.sh; }
step_format() { bash tools/format.sh --check; }
step_build() { build_preset "$preset"; }
step_suite() { ctest --preset "$preset" -j "$jobs" --timeout 900; }
step_asan() {
  build_preset asan
  # The end-to-end localization runs (EndToEnd.*, RealData.*, the ROS nodes' RosNode.*, Ros2Node.*, Ros2RealData.*
  # and the node core's runs but its hostile messages) take 5 to more than 15 minutes each under the sanitizers
  # (docs/robustness.md); their code paths are covered by the smaller filter tests, and they run in the suite above.
  local asan_skip='^(EndToEnd|RealData|RosNode|Ros2Node|Ros2RealData)\.|^LocalizationCoreRun\.(Localizes|ALast|Refuses)'
  # Leaks are reported at exit, after the Vulkan loader unloaded the validation layer; keeping libraries mapped lets
  # tools/lsan.supp name it.
  cc -O2 -shared -fPIC -o build/asan/keep_libraries_loaded.so tools/keep_libraries_loaded.c
  # ctest -j starts the longest tests first when it knows their costs; a clean checkout's sanitizer build has none,
  # so it borrows those the suite step just measured (the same tests, 6-20x faster there) instead of finishing on the
  # longest one alone.
  local costs=Testing/Temporary/CTestCostData.txt
  if [ ! -f "build/asan/$costs" ] && [ -f "build/$preset/$costs" ]; then
    mkdir -p "build/asan/${costs%/*}" && cp "build/$preset/$costs" "build/asan/$costs"
  fi
  # allocator_may_return_null: libhdf5 handles a failed malloc of a size read from a corrupt file (fuzz/regressions).
  LD_PRELOAD="$PWD/build/asan/keep_libraries_loaded.so" ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 \
    UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 LSAN_OPTIONS=suppressions="$PWD/tools/lsan.supp" \
    ctest --preset asan -j "$jobs" --timeout 900 -E "$asan_skip"
}
step_arm64() {
  tsdf_mcl_build_env
  bash tools/setup.sh --arm64
  bash tools/test_arm64.sh
}
step_fuzz() { bash tools/fuzz.sh "${TSDF_MCL_FUZZ_SECONDS:-20}"; }

STEPS=(setup format build suite)
[ "$full" = 1 ] && STEPS+=(arm64 asan fuzz)

start=$SECONDS
for s in "${STEPS[@]}"; do
  step "$s"
  t0=$SECONDS
  "step_$s"
  printf '==> test.sh: %s done in %d s\n' "$s" $((SECONDS - t0)) >&2
done
printf '\n==> test.sh: all steps passed in %d s (%s)\n' $((SECONDS - start)) "${STEPS[*]}" >&2
