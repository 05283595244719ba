#!/usr/bin/env bash
# Makes a self-contained folder that runs tsdf-mcl (bench above all) on a Linux machine with nothing installed but
# a GPU driver: the program, every shared library it loads except glibc's (libstdc++, OpenMP, Embree, HDF5, Cairo,
# yaml-cpp, ... and the Vulkan loader libvulkan.so.1), and two scripts:
#   tsdf-mcl       runs the program with the bundled libraries, the Vulkan loader pointed at the machine's NVIDIA
#                  ICD (VK_ICD_FILENAMES and VK_DRIVER_FILES; set either yourself to choose another driver)
#   run_bench.sh   simulates a short route in the built-in office, builds its map and runs
#                  `bench --particles 50000,100000,1000000` and `bench --profile` on the GPU, JSON lines to stdout
# glibc is not bundled (it must match the machine's kernel interface and loader): the target needs a glibc at
# least as new as the build machine's symbols ask (the script prints that version).
# Usage: tools/bundle.sh [BUILD_DIR (default build/ci)] [OUT_DIR (default BUILD_DIR/bundle/tsdf-mcl)]
set -euo pipefail
build=${1:-build/ci}
out=${2:-$build/bundle/tsdf-mcl}
program="$build/tools/tsdf-mcl"
bench="$build/tools/tsdf-mcl-bench"  # what `tsdf-mcl bench` runs, from beside the program
for f in "$program" "$bench"; do
  [ -x "$f" ] || { echo "bundle.sh: no $f (build first: cmake --build --preset ci)" >&2; exit 1; }
done
rm -rf "$out"
mkdir -p "$out/bin" "$out/lib"
cp "$program" "$bench" "$out/bin/"

# glibc's own libraries and the dynamic loader stay the machine's.
system='^(linux-vdso|linux-gate|ld-linux[^ ]*|libc|libm|libdl|libpthread|librt|libresolv|libutil|libanl|libmvec)\.so'
ldd "$program" "$bench" | awk '$2 == "=>" && $3 ~ /^\// {print $1, $3}' | sort -u | while read -r name path; do
  [[ "$name" =~ $system ]] && continue
  cp -L "$path" "$out/lib/$name"
done
[ -f "$out/lib/libvulkan.so.1" ] || { echo "bundle.sh: the program does not load libvulkan.so.1?" >&2; exit 1; }
# NVIDIA's Vulkan ICD (libGLX_nvidia.so.0) needs glvnd's libEGL, libGLdispatch and libGLX, which a machine with the
# driver alone (a container with the driver mounted, as on the H200 machine tried here) may lack: "Could not get
# 'vkCreateInstance' via 'vk_icdGetInstanceProcAddr' for ICD libGLX_nvidia.so.0" (libEGL.so.1 was the one missing
# there). Bundled from beside the Vulkan loader where this machine has them (Debian: libegl1, libglvnd0, libglx0).
vulkan_dir=$(dirname "$(ldd "$program" | awk '$1 == "libvulkan.so.1" {print $3}')")
for glvnd in libEGL.so.1 libGLdispatch.so.0 libGLX.so.0; do
  if [ -e "$vulkan_dir/$glvnd" ]; then
    cp -L "$vulkan_dir/$glvnd" "$out/lib/$glvnd"
  else
    echo "bundle.sh: no $glvnd here (libegl1, libglvnd0, libglx0): a GPU machine without it may not load NVIDIA's" \
      "Vulkan driver" >&2
  fi
done

cat >"$out/tsdf-mcl" <<'SCRIPT'
#!/bin/sh
# tsdf-mcl from this folder: its own libraries, the machine's GPU driver. The Vulkan loader is pointed at the
# NVIDIA ICD where one is installed (desktop drivers: /usr/share/vulkan/icd.d or /etc/vulkan/icd.d; Jetson's
# JetPack: /etc/vulkan/icd.d/nvidia_icd.json; a container with the driver mounted under /usr/local/nvidia:
# /usr/local/nvidia/share/vulkan/icd.d) unless VK_ICD_FILENAMES or VK_DRIVER_FILES is already set; without one
# the loader searches its usual places and `--backend auto` falls back to the CPU where it finds no GPU.
here=$(cd "$(dirname "$0")" && pwd)
if [ -z "${VK_ICD_FILENAMES:-}" ] && [ -z "${VK_DRIVER_FILES:-}" ]; then
  icd_dirs="/etc/vulkan/icd.d /usr/share/vulkan/icd.d /usr/local/share/vulkan/icd.d /usr/local/nvidia/share/vulkan/icd.d"
  for dir in ${TSDF_MCL_ICD_DIRS:-$icd_dirs}; do
    for icd in "$dir"/nvidia_icd*.json; do
      if [ -f "$icd" ]; then
        VK_ICD_FILENAMES=$icd
        VK_DRIVER_FILES=$icd
        export VK_ICD_FILENAMES VK_DRIVER_FILES
        break 2
      fi
    done
  done
  [ -n "${VK_ICD_FILENAMES:-}" ] || echo "tsdf-mcl (bundle): no NVIDIA Vulkan ICD found; the loader searches its default places" >&2
fi
LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export LD_LIBRARY_PATH
exec "$here/bin/tsdf-mcl" "$@"
SCRIPT

cat >"$out/run_bench.sh" <<'SCRIPT'
#!/bin/sh
# The sensor-update benchmark on this machine's GPU: a 2 m route in the built-in office, its map from the scene
# mesh (0.05 m voxels), then bench on the vulkan and cpu backends (50k, 100k, 1M particles; JSON lines) and one
# --profile run (per-pass GPU times, shader statistics). Usage: run_bench.sh [WORK_DIR] [bench options...]
set -eu
here=$(cd "$(dirname "$0")" && pwd)
work=${1:-${TMPDIR:-/tmp}/tsdf-mcl-bench}
[ $# -gt 0 ] && shift
mkdir -p "$work"
if [ ! -f "$work/office.tsdf" ]; then
  rm -rf "$work/route"
  "$here/tsdf-mcl" simulate --scene office --route test --length 2 --start 5,5,0 -o "$work/route" >&2
  "$here/tsdf-mcl" build-map --mesh "$work/route/scene.ply" --voxel 0.05 -o "$work/office.tsdf" >&2
fi
"$here/tsdf-mcl" info "$work/office.tsdf" >&2
"$here/tsdf-mcl" bench --map "$work/office.tsdf" --dataset "$work/route" --particles 50000,100000,1000000 \
  --backend vulkan,cpu "$@"
"$here/tsdf-mcl" bench --map "$work/office.tsdf" --dataset "$work/route" --particles 100000 --backend vulkan \
  --profile "$@"
SCRIPT
chmod +x "$out/tsdf-mcl" "$out/run_bench.sh"

glibc=$(objdump -T "$out"/bin/* "$out"/lib/*.so* 2>/dev/null | grep -o 'GLIBC_[0-9.]*' | sort -uV | tail -n 1)
echo "bundle.sh: $out ($(du -sh "$out" | cut -f1), $(ls "$out/lib" | wc -l) libraries; needs ${glibc:-glibc} or newer)"
