#!/usr/bin/env bash
# Formats the C++ sources with .clang-format (Debian 12's clang-format 14), or with --check lists the files that
# differ from it and fails. The GLSL shaders and their shared header are formatted by hand.
set -euo pipefail
cd "$(dirname "$0")/.."
format=$(command -v clang-format-14 || command -v clang-format || true)
[ -n "$format" ] || { echo "format.sh: clang-format is not installed (apt-get install clang-format-14)" >&2; exit 1; }
mapfile -t files < <(git ls-files --cached --others --exclude-standard -- 'src/*' 'include/*' 'tools/*' 'tests/*' 'bench/*' 'fuzz/*' 'ros/*' 'ros2/*' 'node_core/*' 'python/*' |
                     grep -E '\.(cpp|hpp|h|c)$' | grep -v '^shaders/' | while read -r f; do [ -e "$f" ] && echo "$f"; done)
if [ "${1:-}" = "--check" ]; then
  bad=0
  for f in "${files[@]}"; do
    if ! "$format" --dry-run -Werror "$f" >/dev/null 2>&1; then echo "format.sh: $f differs from .clang-format" >&2; bad=1; fi
  done
  [ "$bad" = 0 ] || { echo "format.sh: run bash tools/format.sh to fix" >&2; exit 1; }
  echo "format.sh: ${#files[@]} files follow .clang-format" >&2
else
  "$format" -i "${files[@]}"
fi
