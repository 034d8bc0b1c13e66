#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Runs each libFuzzer target of build/asan (cmake --preset asan; cmake --build
# --preset fuzz) for SECONDS on its seed corpus (fuzz/corpus/<target>/, read
# only) and its working corpus (build/asan/fuzz-corpus/<target>/, where new
# inputs go), then prints a table of the executions and the result. A crash,
# sanitizer report, leak, timeout (10 s an input) or out-of-memory input leaves
# build/asan/fuzz-findings/<target>-<kind>-... and fails the run. FUZZ_JOBS
# targets run at a time (default: one a core).
#   scripts/run-fuzzers.sh SECONDS [TARGET ...]      (default: every target)
#   scripts/run-fuzzers.sh --runs N [TARGET ...]     each target until N executions
set -uo pipefail
cd "$(dirname "$0")/.."
usage="usage: run-fuzzers.sh SECONDS|--runs N [TARGET ...]"
if [[ ${1:-} == --runs ]]; then
  limit=-runs=${2:?$usage}
  shift 2
else
  limit=-max_total_time=${1:?$usage}
  shift
fi
targets=("$@")
if [[ ${#targets[@]} -eq 0 ]]; then
  for f in build/asan/fuzz/fuzz_*; do targets+=("${f##*/fuzz_}"); done
fi
# The targets write each input to a file: a memory file system when there is one.
if [[ -d /dev/shm && -w /dev/shm ]]; then export TMPDIR=/dev/shm; fi
mkdir -p build/asan/fuzz-findings build/asan/fuzz-logs
jobs=${FUZZ_JOBS:-$(nproc)}
fuzz_one() {  # fuzz_one TARGET: runs it, leaves its row of the table in build/asan/fuzz-logs/TARGET.row
  local t=$1 exe=build/asan/fuzz/fuzz_$1 log=build/asan/fuzz-logs/$1.log rc runs time corpus result
  mkdir -p "build/asan/fuzz-corpus/$t"
  "$exe" "$limit" -timeout=10 -rss_limit_mb=4096 -print_final_stats=1 \
    -artifact_prefix="build/asan/fuzz-findings/$t-" "build/asan/fuzz-corpus/$t" "fuzz/corpus/$t" >"$log" 2>&1
  rc=$?
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  time=$(sed -n 's/^Done [0-9]* runs in \([0-9]*\) second.*/\1 s/p' "$log" | tail -1)
  corpus=$(find "build/asan/fuzz-corpus/$t" -type f | wc -l)
  if [[ $rc -eq 0 ]]; then result=clean; else
    result="FAILED (exit $rc; $(grep -m1 -oE 'ERROR: [A-Za-z]+: [^ ]+( [^ ]+)?|libFuzzer: [a-z-]+' "$log" || echo see log), $log"
  fi
  printf '%-26s %12s %8s %8s  %s\n' "$t" "${runs:-?}" "${time:-?}" "$corpus" "$result" | tee "build/asan/fuzz-logs/$t.row"
}
for t in "${targets[@]}"; do
  if [[ ! -x build/asan/fuzz/fuzz_$t ]]; then echo "run-fuzzers: no target build/asan/fuzz/fuzz_$t (make fuzz builds them)" >&2; exit 2; fi
  rm -f "build/asan/fuzz-logs/$t.row"
done
for t in "${targets[@]}"; do
  while [[ $(jobs -rp | wc -l) -ge $jobs ]]; do wait -n; done
  fuzz_one "$t" &
done
wait
echo
printf '%-26s %12s %8s %8s  %s\n' target executions time corpus result
status=0
for t in "${targets[@]}"; do
  if [[ ! -f build/asan/fuzz-logs/$t.row ]]; then
    printf '%-26s  FAILED (no result: the run script stopped)\n' "$t"
    status=1
    continue
  fi
  cat "build/asan/fuzz-logs/$t.row"
  if ! grep -q ' clean$' "build/asan/fuzz-logs/$t.row"; then status=1; fi
done
exit $status
