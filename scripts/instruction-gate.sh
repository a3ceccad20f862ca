#!/usr/bin/env bash
# The instruction-count gate: instructions executed by one step of `drop` (Newton; in fast mode, its
# next step that factors afresh), ten frames of bench-peers' rope (rope-frame), one skinning of a
# 10,000-vertex mesh, and a render thread's acquire of it skinned on the CPU or as rings for a GPU
# (bench/gate.cpp), counted by callgrind, against bench/baselines/instructions.txt.
# Counts are repeatable for the same binary whatever else the machine is doing; the gate fails when
# a workload executes more than TOLERANCE (3 %) over its baseline.
#   scripts/instruction-gate.sh            check (part of `make test`)
#   scripts/instruction-gate.sh --update   record the current counts as the baseline
set -euo pipefail
cd "$(dirname "$0")/.."
gate=build/release/bin/haustra_gate
baseline=bench/baselines/instructions.txt
tolerance_percent=3
workloads=(drop-frame drop-fast-frame rope-frame ropes-sleeping-frame range-sleeping-frame skin-10k reader-cpu-10k reader-gpu-10k)
[[ -x "$gate" ]] || { echo "instruction-gate: build first ($gate is missing)" >&2; exit 1; }
command -v valgrind >/dev/null || { echo "instruction-gate: valgrind is missing (scripts/install-deps.sh installs it)" >&2; exit 1; }

count() {
  local out
  out=$(mktemp)
  valgrind --tool=callgrind --instr-atstart=no --collect-atstart=no --callgrind-out-file="$out" "$gate" "$1" >/dev/null 2>&1
  # "totals" is what was collected (with --collect-atstart=no, "summary" stays 0).
  awk '/^totals:/ {print $2; exit}' "$out"
  rm -f "$out"
}

# The workloads at once (a core each where there are enough): the counts do not depend on what else runs.
declare -A now
tmp=$(mktemp -d)
for w in "${workloads[@]}"; do count "$w" > "$tmp/$w" & done
wait
for w in "${workloads[@]}"; do
  now[$w]=$(cat "$tmp/$w")
  [[ "${now[$w]:-0}" -gt 0 ]] || { echo "instruction-gate: callgrind counted nothing for $w" >&2; exit 1; }
done
rm -rf "$tmp"

if [[ "${1:-}" == "--update" ]]; then
  {
    echo "# instructions per workload (scripts/instruction-gate.sh --update, $(date -u +%Y-%m-%d))"
    for w in "${workloads[@]}"; do echo "$w ${now[$w]}"; done
  } > "$baseline"
  echo "instruction-gate: baseline updated in $baseline"
  cat "$baseline"
  exit 0
fi

status=0
printf "%-12s %14s %14s %9s\n" workload baseline now change
for w in "${workloads[@]}"; do
  base=$(awk -v w="$w" '$1 == w {print $2}' "$baseline")
  [[ -n "$base" ]] || { echo "instruction-gate: no baseline for $w in $baseline (run with --update)" >&2; exit 1; }
  change=$(awk -v a="${now[$w]}" -v b="$base" 'BEGIN {printf "%+.2f", 100 * (a - b) / b}')
  printf "%-12s %14s %14s %8s%%\n" "$w" "$base" "${now[$w]}" "$change"
  if awk -v c="$change" -v t="$tolerance_percent" 'BEGIN {exit !(c > t)}'; then
    echo "instruction-gate: $w executes $change % more instructions than its baseline (tolerance +$tolerance_percent %)" >&2
    status=1
  elif awk -v c="$change" 'BEGIN {exit !(c < -5)}'; then
    echo "instruction-gate: $w got faster; record it with scripts/instruction-gate.sh --update"
  fi
done
exit $status
