#!/usr/bin/env bash
# `make fuzz`: runs each libFuzzer target (fuzz/) for FUZZ_SECONDS (default 300), all at once;
# `scripts/fuzz.sh mesh` runs one.
# New inputs go to out/fuzz/<target>/ and are then merged into the committed corpus
# fuzz/corpus/<target>/ only where they add coverage. A crash leaves out/fuzz/<target>-crash-*:
# copy it into tests/fuzz-regressions/<target>/, fix the bug, and the replay test keeps it fixed.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${FUZZ_SECONDS:-300}
bin=build/fuzz/bin
targets=("${@:-scene}")
[[ $# -gt 0 ]] || targets=(scene centreline mesh c_api)
mkdir -p out/fuzz
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:allocator_may_return_null=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0
pids=()
for t in "${targets[@]}"; do
  mkdir -p "out/fuzz/$t"
  "$bin/haustra_fuzz_$t" "out/fuzz/$t" "fuzz/corpus/$t" -max_total_time="$seconds" -timeout=20 -rss_limit_mb=4096 \
    -artifact_prefix="out/fuzz/$t-" -print_final_stats=1 >"out/fuzz/$t.log" 2>&1 &
  pids+=($!)
done
failed=0
for i in "${!targets[@]}"; do
  t=${targets[$i]}
  if wait "${pids[$i]}"; then
    echo "fuzz $t: ${seconds} s, no crash ($(grep -m1 -o 'stat::number_of_executed_units: *[0-9]*' "out/fuzz/$t.log" | grep -o '[0-9]*$') runs)"
  else
    echo "fuzz $t: FOUND A CRASH, see out/fuzz/$t.log and out/fuzz/$t-*" >&2
    failed=1
  fi
done
for t in "${targets[@]}"; do
  "$bin/haustra_fuzz_$t" -merge=1 "fuzz/corpus/$t" "out/fuzz/$t" >>"out/fuzz/$t.log" 2>&1
  echo "fuzz $t: corpus fuzz/corpus/$t now $(ls "fuzz/corpus/$t" | wc -l) inputs"
done
exit $failed
