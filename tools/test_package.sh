#!/usr/bin/env bash
# Builds the Debian packages of a (native) build folder with CPack and checks what a clean machine would get:
#   1. the packages exist with their contents (program; static libraries + CMake package; the ROS node if built);
#   2. every shared library the program and the node load is provided by a package their Depends name
#      (readelf NEEDED -> dpkg -S), and apt can satisfy those Depends (apt-get install --simulate ./PKG.deb);
#   3. the program unpacked from its package alone (dpkg -x into an empty folder) answers --help and runs a tiny
#      localization (a 2 m simulated route in the office, its map from the scene mesh, 300 particles on the CPU),
#      which must stay localized.
# Why dpkg -x + the NEEDED/Depends check rather than installing into a debootstrap chroot: a chroot needs root and
# minutes of downloads per run; the check above finds the same thing a clean install would (a library the
# Depends forget) from the binaries themselves. Usage: tools/test_package.sh BUILD_DIR [WORK_DIR]
set -euo pipefail
build=$(realpath "${1:?usage: test_package.sh BUILD_DIR [WORK_DIR]}")
work=${2:-$(mktemp -d)}
rm -rf "$work" && mkdir -p "$work"
work=$(realpath "$work")
fail() { echo "test_package.sh: $*" >&2; exit 1; }
# A command failing under set -e says where (a silent exit 1 in CI told nothing).
trap 'echo "test_package.sh: line $LINENO failed: $BASH_COMMAND" >&2' ERR

(cd "$work" && cpack -G DEB --config "$build/CPackConfig.cmake" -B "$work/pkgs" >"$work/cpack.log" 2>&1) ||
  { cat "$work/cpack.log" >&2; fail "cpack failed"; }
arch=$(dpkg --print-architecture)
cli=$(ls "$work"/pkgs/tsdf-mcl_*_"$arch".deb 2>/dev/null) || fail "no tsdf-mcl_*_$arch.deb"
dev=$(ls "$work"/pkgs/libtsdf-mcl-dev_*_"$arch".deb 2>/dev/null) || fail "no libtsdf-mcl-dev_*_$arch.deb"
ros=$(ls "$work"/pkgs/tsdf-mcl-ros_*_"$arch".deb 2>/dev/null || true)
if grep -q '^TSDF_MCL_HAVE_ROS_NODE:INTERNAL=ON' "$build/CMakeCache.txt" 2>/dev/null ||
  grep -q 'CPACK_COMPONENTS_ALL.*ros' "$build/CPackConfig.cmake"; then
  [ -n "$ros" ] || fail "the ROS node is built but there is no tsdf-mcl-ros package"
fi

# 1. contents (listed to files first: grep -q closing a pipe would fail dpkg-deb under pipefail)
dpkg-deb -c "$cli" >"$work/cli.list"
dpkg-deb -c "$dev" >"$work/dev.list"
for f in tsdf-mcl tsdf-mcl-bench; do
  grep -q "\./usr/bin/$f\$" "$work/cli.list" || fail "$cli lacks usr/bin/$f"
done
for f in 'include/tsdf_mcl/cpu/cpu_evaluator.hpp' 'cmake/tsdf_mcl/tsdf_mclConfig.cmake' 'libtsdf_mcl_core.a' \
  'pkgconfig/tsdf_mcl.pc'; do
  grep -q "$f\$" "$work/dev.list" || fail "$dev lacks $f"
done
ros_node=
if [ -n "$ros" ]; then
  dpkg-deb -c "$ros" >"$work/ros.list"
  ros_node=$(awk '/\/tsdf_mcl_node$/ {print substr($NF, 2)}' "$work/ros.list")
  [ -n "$ros_node" ] || fail "$ros lacks tsdf_mcl_node"
fi
if grep -q '\.a$\|/include/' "$work/cli.list"; then fail "$cli carries the library's files"; fi

# 2. Depends against what the binaries load
owner() {  # the package owning a library path, under any of the names usr-merge gives it
  local real=$1 candidate
  real=$(realpath "$1")
  for candidate in "$1" "$real" "${1#/usr}" "/usr$1" "${real#/usr}"; do
    dpkg -S "$candidate" 2>/dev/null | head -n 1 | cut -d: -f1 | grep . && return 0
  done
  return 1
}
check_depends() {  # deb, binary path inside it
  local deb=$1 bin=$2 root="$work/x-$(basename "$1" .deb)"
  dpkg-deb -x "$deb" "$root"
  local depends
  depends=$(dpkg-deb -f "$deb" Depends | tr ',' '\n' | sed 's/^ *//; s/[ (|].*//' | grep -v '^$')
  readelf -d "$root$bin" | sed -n 's/.*NEEDED.*\[\(.*\)\]/\1/p' >"$root.needed"
  # The cache listed to a file first: awk leaving at its first match would end ldconfig with SIGPIPE, which
  # pipefail turns into a failure (it did, now and then, in CI).
  ldconfig -p >"$work/ldconfig.txt"
  for lib in $(cat "$root.needed"); do
    local path pkg
    path=$(awk -v l="$lib" '$1 == l && /x86-64|AArch64/ {print $NF; exit}' "$work/ldconfig.txt")
    [ -n "$path" ] || fail "$bin needs $lib, which is not installed here"
    pkg=$(owner "$path") || fail "no package owns $path ($lib, loaded by $bin)"
    # A here-string, not `echo | grep -q`: under pipefail, grep leaving at its match while echo still wrote the
    # last line failed the pipeline on a loaded machine ("libvulkan1 ... which its Depends do not name", with
    # libvulkan1 in them).
    grep -qx "$pkg" <<<"$depends" || {
      echo "Depends of $(basename "$deb"): $(echo "$depends" | tr '\n' ' ')" >&2
      grep -i 'shlibdeps\|warning' "$work/cpack.log" >&2 || true
      fail "$(basename "$deb") loads $lib from $pkg, which its Depends do not name"
    }
  done
  apt-get install --simulate -qq "$deb" >"$work/apt-$(basename "$deb").log" 2>&1 ||
    { cat "$work/apt-$(basename "$deb").log" >&2; fail "apt cannot satisfy the Depends of $(basename "$deb")"; }
}
check_depends "$cli" /usr/bin/tsdf-mcl
check_depends "$cli" /usr/bin/tsdf-mcl-bench
[ -z "$ros" ] || check_depends "$ros" "$ros_node"
apt-get install --simulate -qq "$dev" >"$work/apt-dev.log" 2>&1 ||
  { cat "$work/apt-dev.log" >&2; fail "apt cannot satisfy the Depends of $(basename "$dev")"; }

# 3. the unpacked program
bin="$work/x-$(basename "$cli" .deb)/usr/bin/tsdf-mcl"
"$bin" --help >"$work/help.txt"
grep -q '^  localize' "$work/help.txt" || fail "tsdf-mcl --help from the package lists no localize command"
cd "$work"
"$bin" simulate --scene office --route test --length 2 --start 5,5,0 -o route >sim.log 2>&1 || { cat sim.log >&2; fail "simulate failed"; }
"$bin" build-map --mesh route/scene.ply --voxel 0.1 -o office.tsdf >map.log 2>&1 || { cat map.log >&2; fail "build-map failed"; }
init=$(awk 'NR == 1 {printf "%s,%s,%s,0,0,%.5f", $4, $8, $12, atan2($5, $1)}' route/poses.txt)
"$bin" localize --map office.tsdf --dataset route --backend cpu --particles 300 --init "$init" --seed 1 -o run \
  >localize.log 2>&1 || { cat localize.log >&2; fail "localize failed"; }
"$bin" evaluate --estimate run/trajectory.tum --dataset route >evaluate.json 2>evaluate.log ||
  { cat evaluate.log >&2; fail "evaluate failed"; }
fraction=$(sed -n 's/^  "localized_fraction": \([0-9.]*\),*$/\1/p' evaluate.json)
[ -n "$fraction" ] || { cat evaluate.json >&2; fail "evaluate printed no localized_fraction"; }
awk -v f="$fraction" 'BEGIN {exit !(f >= 0.9)}' || fail "the packaged program localized only $fraction of the scans"
# bench runs the packaged benchmark program beside tsdf-mcl.
"$bin" bench --map office.tsdf --dataset route --particles 100 --points 32 --backend cpu --repetitions 1 \
  --warmup 0 >bench.json 2>bench.log || { cat bench.log >&2; fail "bench failed"; }
grep -q '"backend":"cpu"' bench.json || { cat bench.json >&2; fail "bench printed no measurement"; }
echo "test_package.sh: $(cd "$work/pkgs" && ls ./*.deb | tr '\n' ' ')OK (localized fraction $fraction)"
