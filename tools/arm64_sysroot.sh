#!/usr/bin/env bash
# Builds the arm64 sysroot the cross build (cmake --preset arm64) links against and qemu-aarch64 runs in: Debian 12's
# arm64 packages, resolved by apt through multiarch (dpkg --add-architecture arm64) but unpacked with dpkg -x into a
# folder instead of installed. Why not `apt-get install libhdf5-dev:arm64 ...`: libhdf5-dev and libyaml-cpp-dev are
# not Multi-Arch: same, so installing their arm64 builds REMOVES the host's, and every Multi-Arch: same library
# forces the host's copy to the same version (systemd, OpenSSL upgraded under a running machine). The sysroot
# touches nothing of the host. Usage: tools/arm64_sysroot.sh [DIR] (default /opt/tsdf-mcl/arm64-sysroot; also
# TSDF_MCL_ARM64_SYSROOT). Needs the arm64 package indexes (root: dpkg --add-architecture arm64 && apt-get update,
# which tools/setup.sh --arm64 does); the unpacking itself needs no root where DIR is writable.
set -euo pipefail

root=${1:-${TSDF_MCL_ARM64_SYSROOT:-/opt/tsdf-mcl/arm64-sysroot}}
# What the project links (the -dev packages), runs its tests on (lavapipe, the validation layers) and the C/C++
# runtime. ROS 1 is left out on arm64 (see docs/deploy.md).
packages=(
  libc6-dev libstdc++-12-dev libgomp1
  libeigen3-dev libglm-dev nlohmann-json3-dev libnanoflann-dev
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers
  libhdf5-dev libembree-dev libyaml-cpp-dev libcairo2-dev fonts-dejavu-core libgtest-dev zlib1g-dev
  libsqlite3-dev libzstd-dev liblz4-dev
)

if ! grep -qx arm64 <<<"$(dpkg --print-foreign-architectures)"; then
  echo "arm64_sysroot.sh: arm64 is not a dpkg architecture here; run tools/setup.sh --arm64 (as root)" >&2
  exit 1
fi
stamp="$root/.tsdf-mcl-packages"
stamp_text="format 3: ${packages[*]}"  # bump the format when this script changes what it unpacks
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$stamp_text" ]; then
  echo "arm64_sysroot.sh: $root is up to date"
  exit 0
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# An empty dpkg status: apt resolves the whole dependency closure for arm64 as if nothing were installed.
: >"$work/status"
apt_arm64=(-o Dir::State::status="$work/status" -o APT::Architecture=arm64 -o APT::Architectures::=arm64
  -o APT::Architectures::=all -o Debug::NoLocking=1)
apt-get "${apt_arm64[@]}" install -s -y --no-install-recommends "${packages[@]}" >"$work/plan" ||
  {
    cat "$work/plan" >&2
    echo "arm64_sysroot.sh: apt could not resolve the arm64 packages (apt-get update after adding arm64?)" >&2
    exit 1
  }
# "Inst name (version suite [arch]) [...]" -> name:arch=version
sed -n 's/^Inst \([^ ]*\) (\([^ ]*\) [^[]*\[\([a-z0-9]*\)\]).*$/\1:\3=\2/p' "$work/plan" >"$work/list"
if [ -e "$root" ] && [ ! -f "$stamp" ] && [ -n "$(ls -A "$root")" ]; then
  echo "arm64_sysroot.sh: $root exists and is not a sysroot this script made; remove it or pick another folder" >&2
  exit 1
fi
rm -rf "$root"
echo "arm64_sysroot.sh: fetching $(wc -l <"$work/list") packages into $root"
mkdir -p "$work/debs" "$root"
(cd "$work/debs" && xargs -a "$work/list" apt-get "${apt_arm64[@]}" download -qq)
for deb in "$work"/debs/*.deb; do dpkg-deb -x "$deb" "$root"; done
# Absolute symlinks (libfoo.so -> /lib/...) would point at the host's files: make them relative to the sysroot.
find "$root" -type l -lname '/*' | while read -r link; do
  target=$(readlink "$link")
  ln -sfn "$(realpath -m --relative-to="$(dirname "$link")" "$root$target")" "$link"
done
# Debian 12 merges /lib into /usr/lib; the packages still ship some files under /lib (the dynamic loader).
for d in lib; do
  if [ -d "$root/$d" ] && [ ! -L "$root/$d" ]; then
    cp -a "$root/$d/." "$root/usr/$d/" && rm -rf "${root:?}/$d" && ln -s "usr/$d" "$root/$d"
  elif [ ! -e "$root/$d" ]; then
    ln -s "usr/$d" "$root/$d"
  fi
done
echo "$stamp_text" >"$stamp"
echo "arm64_sysroot.sh: done ($(du -sh "$root" | cut -f1))"
