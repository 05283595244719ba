#!/usr/bin/env bash
# How fast the bag readers read a large bag (docs/bags.md): one simulated run of about 1 GB (OS0-64, the test
# route of the office) written as every format BagWriter writes, each read as localize reads it (open, then every
# scan) by bench/bag_read_bench.cpp. One JSON line per bag on stdout; the bags are removed as they are measured.
#
#   bash bench/rosbag2_readers.sh [--length M] [--out DIR] [--cli PATH] [--bench PATH]
#
# Default: --length 52 (about 960 scans of 65,536 points, 1.0 GB as MCAP). The first read of each bag comes after its writing, so
# it is from the page cache, as a second localize of the same bag would be.
set -euo pipefail
cd "$(dirname "$0")/.."

length=52 out=out/rosbag2_readers cli=build/release/tools/tsdf-mcl bench=build/release/bench/bag_read_bench
while [ $# -gt 0 ]; do
  case "$1" in
    --length) length=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --cli) cli=$2; shift 2 ;;
    --bench) bench=$2; shift 2 ;;
    *) echo "rosbag2_readers.sh: unknown option $1" >&2; exit 2 ;;
  esac
done

mkdir -p "$out"
if [ ! -f "$out/run/times.txt" ]; then
  "$cli" simulate --scene office --lidar os0-64 --route test --seed 1 --length "$length" -o "$out/run" --quiet
fi
measure() {  # NAME [storage] [compression]
  rm -rf "${out:?}/$1"
  "$bench" write "$out/run" "$out/$1" "${2:-mcap}" "${3:-none}"
  "$bench" read "$out/$1"
  rm -rf "${out:?}/$1"
}
measure run.mcap
measure zstd.mcap mcap zstd
measure lz4.mcap mcap lz4
measure run.db3
measure folder_sqlite3 sqlite3  # a rosbag2 folder of SQLite3 storage
if [ "$("$bench" ros1)" = 1 ]; then measure run.bag; fi  # where the build reads ROS 1 bags
