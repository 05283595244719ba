#!/usr/bin/env bash
# Installs what is missing, builds (Release, warnings as errors) and runs the whole test suite on lavapipe with the
# Vulkan validation layers on; then runs it again built with clang, ASan and UBSan (any finding fails the run), and
# every fuzzer for a short, bounded time.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
bash tools/format.sh --check
cmake --preset ci >/dev/null
cmake --build --preset ci -j "$(nproc)"
ctest --preset ci -j "$(nproc)" --timeout 900

cmake --preset asan >/dev/null
cmake --build --preset asan -j "$(nproc)"
# The end-to-end localization runs (EndToEnd.*, RealData.*, the ROS node's RosNode.*) take 9 to more than 15 minutes
# each under the sanitizers; their code paths are covered by the smaller filter tests, and they run in the build above.
asan_skip='^(EndToEnd|RealData|RosNode)\.'
# Leaks are reported at exit, after the Vulkan loader unloaded the validation layer; keeping libraries mapped lets
# tools/lsan.supp name it.
cc -O2 -shared -fPIC -o build/asan/keep_libraries_loaded.so tools/keep_libraries_loaded.c
# allocator_may_return_null: libhdf5 handles a failed malloc of a size read from a corrupt file (fuzz/regressions).
LD_PRELOAD="$PWD/build/asan/keep_libraries_loaded.so" ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 \
  UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 LSAN_OPTIONS=suppressions="$PWD/tools/lsan.supp" \
  ctest --preset asan -j "$(nproc)" --timeout 900 -E "$asan_skip"
bash tools/fuzz.sh "${TSDF_MCL_FUZZ_SECONDS:-20}"
