#!/usr/bin/env bash
# Runs clang-tidy (.clang-tidy: bug and performance checks) over the given C++ files, or over every library and
# tool source, with the compile commands of the ci build (cmake --preset ci first). Fails on any finding.
set -euo pipefail
cd "$(dirname "$0")/.."
tidy=$(command -v clang-tidy-14 || command -v clang-tidy || true)
[ -n "$tidy" ] || { echo "tidy.sh: clang-tidy is not installed (apt-get install clang-tidy-14)" >&2; exit 1; }
[ -e build/ci/compile_commands.json ] || { echo "tidy.sh: no build/ci/compile_commands.json (run cmake --preset ci)" >&2; exit 1; }
if [ $# -gt 0 ]; then files=("$@"); else mapfile -t files < <(git ls-files --cached --others --exclude-standard -- 'src/*.cpp' 'tools/*.cpp'); fi
out=$(printf '%s\n' "${files[@]}" | xargs -P "$(nproc)" -n 4 "$tidy" -p build/ci --quiet 2>/dev/null | grep -E 'warning:|error:' | sort -u || true)
if [ -n "$out" ]; then echo "$out"; echo "tidy.sh: $(echo "$out" | wc -l) findings" >&2; exit 1; fi
echo "tidy.sh: ${#files[@]} files clean" >&2
