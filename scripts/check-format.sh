#!/usr/bin/env bash
# Every C++ file of the tree in the house style (.clang-format), as `make test` checks it: lists the
# files that differ and the command that formats them. `scripts/check-format.sh --fix` formats them.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
command -v clang-format >/dev/null || { echo "check-format: clang-format is missing (scripts/install-deps.sh installs it)" >&2; exit 2; }
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files '*.cpp' '*.hpp' '*.h' '*.c')
else
  mapfile -t files < <(find kernels engine import studies render tools bench tests fuzz python \
                         \( -name '*.cpp' -o -name '*.hpp' -o -name '*.h' -o -name '*.c' \) | sort)
fi
if [[ "${1:-}" == "--fix" ]]; then
  clang-format -i "${files[@]}"
  exit 0
fi
# One clang-format for every file (a process per file took 8 s); its errors name the files.
bad=()
if ! report=$(clang-format --dry-run --Werror "${files[@]}" 2>&1 >/dev/null); then
  mapfile -t bad < <(printf '%s\n' "$report" | sed -n 's/^\([^:]*\):[0-9]*:[0-9]*: error: .*/\1/p' | sort -u)
  [[ ${#bad[@]} -gt 0 ]] || bad=("(clang-format failed: $report)")
fi
if [[ ${#bad[@]} -gt 0 ]]; then
  echo "check-format: ${#bad[@]} of ${#files[@]} files are not in the house style (.clang-format):" >&2
  printf '  %s\n' "${bad[@]}" >&2
  echo "format them with: scripts/check-format.sh --fix" >&2
  exit 1
fi
echo "check-format: ${#files[@]} files in the house style"
