#!/usr/bin/env bash
# Installs the build in BUILD_DIR into a scratch prefix and builds tests/install/consumer against it twice: with
# find_package(tsdf_mcl COMPONENTS ...) and with pkg-config; runs both programs.
#   bash tests/install/check_install.sh BUILD_DIR SCRATCH_DIR
set -euo pipefail
build=$(realpath "$1")
scratch="$2"
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$scratch" && mkdir -p "$scratch"
prefix="$scratch/prefix"
cmake --install "$build" --prefix "$prefix" >/dev/null
[ -x "$prefix/bin/tsdf-mcl" ] || { echo "check_install: no bin/tsdf-mcl in the prefix" >&2; exit 1; }
"$prefix/bin/tsdf-mcl" --help >/dev/null

# The Python module, where the build has it (docs/python.md): below the prefix, importable from there.
if [ -e "$build/python" ]; then
  module=$(find "$prefix" -name 'tsdf_mcl.*.so' | head -n 1)
  [ -n "$module" ] || { echo "check_install: the Python module was not installed" >&2; exit 1; }
  PYTHONPATH=$(dirname "$module") /usr/bin/python3 -c "import tsdf_mcl, sys; assert tsdf_mcl.__file__ == sys.argv[1]" \
    "$module" || { echo "check_install: the installed Python module does not import" >&2; exit 1; }
fi

cmake -S "$here/consumer" -B "$scratch/cmake" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$scratch/cmake" >/dev/null
"$scratch/cmake/consumer"

# Components find only their own dependencies: map, sensor, cpu and filter build with Vulkan, glm, Embree,
# pkg-config (Cairo) and the I/O packages (nanoflann, rosbag_storage, HDF5) made unfindable, and their link line
# names no I/O library nor the io and mapping layers; asking for gpu the same way fails, naming Vulkan.
no_gpu_packages=(-DCMAKE_DISABLE_FIND_PACKAGE_Vulkan=TRUE -DCMAKE_DISABLE_FIND_PACKAGE_glm=TRUE
                 -DCMAKE_DISABLE_FIND_PACKAGE_embree=TRUE -DCMAKE_DISABLE_FIND_PACKAGE_PkgConfig=TRUE)
no_io_packages=(-DCMAKE_DISABLE_FIND_PACKAGE_nanoflann=TRUE -DCMAKE_DISABLE_FIND_PACKAGE_RosbagStorage=TRUE
                -DCMAKE_DISABLE_FIND_PACKAGE_HDF5=TRUE)
cmake -S "$here/consumer" -B "$scratch/cpu_only" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix" \
  -DCONSUMER_CPU_ONLY=ON "${no_gpu_packages[@]}" "${no_io_packages[@]}" >"$scratch/cpu_only.log" 2>&1 ||
  { cat "$scratch/cpu_only.log" >&2; echo "check_install: COMPONENTS map sensor cpu filter needs more than their own" >&2; exit 1; }
link=$(ninja -C "$scratch/cpu_only" -t commands consumer | tail -n 1)
grep -q 'libtsdf_mcl_map\.a' <<<"$link" || { echo "check_install: no link line for the consumer: $link" >&2; exit 1; }
if grep -Eo 'hdf5|nanoflann|rosbag|roscpp|tsdf_mcl_io|tsdf_mcl_mapping' <<<"$link" | sort -u | grep .; then
  echo "check_install: COMPONENTS map sensor cpu filter links the I/O above (link line: $link)" >&2; exit 1
fi
cmake --build "$scratch/cpu_only" >/dev/null
"$scratch/cpu_only/consumer"
mkdir -p "$scratch/gpu"
printf 'cmake_minimum_required(VERSION 3.22)\nproject(gpu LANGUAGES CXX)\nfind_package(tsdf_mcl REQUIRED COMPONENTS gpu)\n' \
  >"$scratch/gpu/CMakeLists.txt"
if cmake -S "$scratch/gpu" -B "$scratch/gpu/build" -DCMAKE_PREFIX_PATH="$prefix" "${no_gpu_packages[@]}" \
  >"$scratch/gpu.log" 2>&1; then
  echo "check_install: COMPONENTS gpu was found without Vulkan" >&2; exit 1
fi
grep -q "Vulkan" "$scratch/gpu.log" || { cat "$scratch/gpu.log" >&2; echo "check_install: the error does not name Vulkan" >&2; exit 1; }

# An unknown component must fail find_package with a message naming it.
mkdir -p "$scratch/bad"
printf 'cmake_minimum_required(VERSION 3.22)\nproject(bad LANGUAGES CXX)\nfind_package(tsdf_mcl REQUIRED COMPONENTS warp_drive)\n' \
  >"$scratch/bad/CMakeLists.txt"
if cmake -S "$scratch/bad" -B "$scratch/bad/build" -DCMAKE_PREFIX_PATH="$prefix" >"$scratch/bad.log" 2>&1; then
  echo "check_install: find_package accepted an unknown component" >&2; exit 1
fi
grep -q "warp_drive" "$scratch/bad.log" || { echo "check_install: the error does not name the component" >&2; exit 1; }

export PKG_CONFIG_PATH="$prefix/lib/pkgconfig${PKG_CONFIG_PATH:+:$PKG_CONFIG_PATH}"
# shellcheck disable=SC2046
c++ -O1 -o "$scratch/consumer_pc" "$here/consumer/consumer.cpp" $(pkg-config --cflags --libs tsdf_mcl)
"$scratch/consumer_pc"

# The ROS package, where the node was built and roslaunch is installed: roslaunch finds the installed node and
# the launch file sets the map and the topics.
if [ -x "$prefix/lib/tsdf_mcl/tsdf_mcl_node" ] && command -v roslaunch >/dev/null; then
  export ROS_PACKAGE_PATH="$prefix/share" CMAKE_PREFIX_PATH="$prefix" ROS_HOME="$scratch/ros"
  args=$(roslaunch --args /tsdf_mcl tsdf_mcl tsdf_mcl.launch map:=/maps/x.tsdf)
  [[ "$args" == *"$prefix/lib/tsdf_mcl/tsdf_mcl_node"* ]] || { echo "check_install: roslaunch runs '$args'" >&2; exit 1; }
  params=$(roslaunch --dump-params tsdf_mcl tsdf_mcl.launch map:=/maps/x.tsdf points:=/lidar/points)
  grep -q "map_file: /maps/x.tsdf" <<<"$params" && grep -q -- "- /lidar/points" <<<"$params" ||
    { echo "check_install: the launch file's parameters are wrong: $params" >&2; exit 1; }
  echo "check_install: roslaunch finds the installed node"
fi
echo "check_install: the installed package builds and runs a consumer (CMake and pkg-config)"
