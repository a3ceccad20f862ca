#!/usr/bin/env bash
# The engine's rooms include only the rooms below them (engine/CMakeLists.txt): sched/ → model/ →
# state/ → step/ and io/ → api/. Fails naming every include that runs the other way (a cycle, like
# model/ and step/ including each other before issue 38). Also that step/ names no description type
# (`*Desc`): the frame reads the model, which holds what it needs (decision 0116); only world_impl.*,
# the API's Impl, keeps the description it was built from. Part of `make test` (ctest).
#   scripts/check-rooms.sh [src-dir]    default: engine/src
set -euo pipefail
cd "$(dirname "$0")/.."
src=${1:-engine/src}
declare -A allowed=(
  [sched]=""
  [model]="sched"
  [state]="sched model"
  [step]="sched model state"
  [io]="sched model state"
  [api]="sched model state step io"
)
[[ -d "$src" ]] || { echo "check-rooms: no folder $src" >&2; exit 2; }
status=0
checked=0
for room in "${!allowed[@]}"; do
  [[ -d "$src/$room" ]] || continue
  while IFS=: read -r file line text; do
    checked=$((checked + 1))
    target=$(sed -E 's/^[[:space:]]*#[[:space:]]*include[[:space:]]*"([a-z_]+)\/.*/\1/' <<<"$text")
    [[ "$target" == "$room" || -z "${allowed[$target]+known}" ]] && continue  # its own, or not a room
    if [[ " ${allowed[$room]} " != *" $target "* ]]; then
      echo "check-rooms: $file:$line includes $target/ — $room/ may include only: ${allowed[$room]:-no other room}"
      status=1
    fi
  done < <(grep -rnE '^[[:space:]]*#[[:space:]]*include[[:space:]]*"[a-z_]+/' "$src/$room" || true)
done
if [[ -d "$src/step" ]]; then
  while IFS=: read -r file line text; do
    case "$(basename "$file")" in world_impl.hpp | world_impl.cpp) continue ;; esac
    name=$(grep -oE '\b[A-Z][A-Za-z]*Desc\b' <<<"$text" | head -1)
    echo "check-rooms: $file:$line names $name — step/ reads the model, never a description (decision 0116)"
    status=1
  done < <(grep -rnE '\b[A-Z][A-Za-z]*Desc\b' "$src/step" | grep -vE '^[^:]+:[0-9]+:[[:space:]]*//' || true)
fi
for dir in "$src"/*/; do
  room=$(basename "$dir")
  [[ -n "${allowed[$room]+known}" ]] || { echo "check-rooms: $src/$room/ is no room this script knows: add it"; status=1; }
done
[[ $checked -gt 0 ]] || { echo "check-rooms: no includes found under $src" >&2; exit 2; }
[[ $status -eq 0 ]] && echo "check-rooms: $checked includes of the rooms checked, none running up; step/ names no description"
exit $status
