#!/usr/bin/env bash
# Installs every Debian 12 package tsdf-mcl needs to build, test and run (as root or through sudo); clang and its
# runtimes (ASan, UBSan, libFuzzer, OpenMP) serve the sanitizer run and the fuzzers; SQLite3, zstd and lz4, ROS 2
# bags (rosbag2, docs/bags.md); Debian's ROS 1 rosbag_storage and message headers, ROS 1 bags (the build leaves
# them out where they are missing); roscpp,
# tf2_ros, rosmaster, roslaunch and rosbag, the ROS 1 node and its test (docs/ros.md; left out where missing);
# pybind11, numpy, pytest and matplotlib, the Python module, its tests and examples (docs/python.md); clang-format
# and clang-tidy, the code style checks. --arm64 also installs the aarch64 cross compiler and qemu-user and unpacks
# the arm64 sysroot (tools/arm64_sysroot.sh; cmake --preset arm64, tools/test_arm64.sh, docs/deploy.md).
set -euo pipefail

arm64=0
[ "${1:-}" = "--arm64" ] && arm64=1

packages=(
  build-essential cmake ninja-build pkg-config git ccache
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools libegl1 libglvnd0 libglx0
  glslc glslang-tools spirv-tools
  libeigen3-dev libglm-dev libgtest-dev
  libhdf5-dev libembree-dev nlohmann-json3-dev libyaml-cpp-dev libcairo2-dev fonts-dejavu-core libnanoflann-dev zlib1g-dev
  libsqlite3-dev libzstd-dev liblz4-dev
  clang-14 libclang-rt-14-dev libomp-14-dev clang-format-14 clang-tidy-14
  librosbag-storage-dev libroscpp-core-dev libstd-msgs-dev libsensor-msgs-dev libnav-msgs-dev libgeometry-msgs-dev
  libtf2-msgs-dev
  pybind11-dev python3-pybind11 python3-dev python3-numpy python3-pytest python3-matplotlib
  libroscpp-dev libtf2-ros-dev libstd-srvs-dev libdiagnostic-msgs-dev python3-rosmaster python3-roslaunch rosout python3-rosbag librosbag-dev
)

if [ "$(id -u)" -eq 0 ]; then
  sudo=()
elif command -v sudo >/dev/null 2>&1; then
  sudo=(sudo)
else
  echo "setup.sh: need root or sudo to install: ${packages[*]}" >&2
  exit 1
fi

if [ "$arm64" = 1 ]; then
  packages+=(g++-aarch64-linux-gnu qemu-user)
  if ! grep -qx arm64 <<<"$(dpkg --print-foreign-architectures)"; then
    "${sudo[@]}" dpkg --add-architecture arm64
    "${sudo[@]}" apt-get update -qq
  fi
fi

missing=()
for p in "${packages[@]}"; do
  grep -q "install ok installed" <<<"$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null)" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup.sh: all packages present"
else
  echo "setup.sh: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${sudo[@]}" apt-get update -qq
  "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
if [ "$arm64" = 1 ]; then
  "${sudo[@]}" bash "$(dirname "$0")/arm64_sysroot.sh"
fi
