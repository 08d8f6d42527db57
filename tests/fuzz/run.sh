#!/bin/sh
# Runs each libFuzzer harness of BUILD_DIR for SECONDS (default 60), one after the other.
# New inputs go to BUILD_DIR/corpus_<harness> (the committed seeds in tests/fuzz/corpus_<harness>
# are only read); crashes, leaks and timeouts to BUILD_DIR/artifacts/<harness>/. Exit 1 if any
# harness found one: add the input to tests/unit/test_fuzz_regressions.c with the fix.
# Usage: tests/fuzz/run.sh [BUILD_DIR] [SECONDS]
set -u
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${1:-$ROOT/build-fuzz}
SECONDS_EACH=${2:-${FUZZ_SECONDS:-60}}
status=0
for h in scene csv; do
  mkdir -p "$OUT/corpus_$h" "$OUT/artifacts/$h"
  echo "fuzz: $h for $SECONDS_EACH s"
  dict=""
  [ -f "$ROOT/tests/fuzz/$h.dict" ] && dict="-dict=$ROOT/tests/fuzz/$h.dict"
  "$OUT/fuzz_$h" $dict -max_total_time="$SECONDS_EACH" -timeout=10 -rss_limit_mb=2048 -max_len=8192 \
    -artifact_prefix="$OUT/artifacts/$h/" -print_final_stats=1 \
    "$OUT/corpus_$h" "$ROOT/tests/fuzz/corpus_$h" > "$OUT/fuzz_$h.log" 2>&1
  rc=$?
  grep -E "^stat::number_of_executed_units|^stat::peak_rss_mb|^Done" "$OUT/fuzz_$h.log" | sed "s/^/fuzz: $h: /"
  if [ $rc -ne 0 ]; then
    status=1
    echo "fuzz: $h FAILED (exit $rc): see $OUT/fuzz_$h.log and $OUT/artifacts/$h/" >&2
    grep -E "ERROR|SUMMARY" "$OUT/fuzz_$h.log" | head -5 >&2
  fi
done
exit $status
