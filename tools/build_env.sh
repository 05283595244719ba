# The one way tools/demo.sh and tools/test.sh configure and build (both source this file; the suite's
# Tools.DemoAndTestShareOneBuildConfiguration checks that they do and that neither configures on its own). A build
# folder configured another way (the demo without the compiler launcher, the test command with it) has other compile
# commands, and the next build recompiled every object: 576 s after the demo on a fresh machine.
#
#   configure_build PRESET [ARGS...]   cmake --preset PRESET [ARGS...], compilers through ccache where tools/setup.sh
#                                      installed it (tools/test_arm64.sh and tools/fuzz.sh configure through it too)
#   build_preset PRESET                configure_build, then build everything of PRESET with every core

# Compilers run through ccache where it is installed, so that a rebuild of unchanged sources (another clone, the
# sanitizer build after a clean checkout) costs little. CCACHE_BASEDIR makes the checkout's paths relative and
# CCACHE_NOHASHDIR leaves the build folder out of the hash (the sanitizer build has debug info, for which ccache would
# otherwise hash it), so that a clone elsewhere (CI's clean clone) hits the cache. The launcher goes into the CMake
# cache explicitly on every configure (the environment only seeds an empty cache) and into the environment for the
# builds the scripts start below them (the arm64 cross build, the installed package's consumer).
tsdf_mcl_build_env() {
  if command -v ccache >/dev/null 2>&1; then
    export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=true CMAKE_C_COMPILER_LAUNCHER=ccache CMAKE_CXX_COMPILER_LAUNCHER=ccache
  else
    unset CMAKE_C_COMPILER_LAUNCHER CMAKE_CXX_COMPILER_LAUNCHER
  fi
}

configure_build() {
  tsdf_mcl_build_env
  local launcher="${CMAKE_CXX_COMPILER_LAUNCHER:-}"
  cmake --preset "$@" -DCMAKE_C_COMPILER_LAUNCHER="$launcher" -DCMAKE_CXX_COMPILER_LAUNCHER="$launcher" >/dev/null
}

build_preset() {
  configure_build "$1"
  cmake --build --preset "$1" -j "$(nproc)"
}
