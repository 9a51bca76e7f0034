#!/usr/bin/env bash
# Runs every test binary in BUILD/tests from the source root and prints one summary
# line, "N passed, N failed", of the cmocka test cases. A binary that crashes or
# exits non-zero without reporting counts as one failed case. Exit status: 0 only
# when nothing failed.
# Usage: tests/run_tests.sh BUILD_DIR [TEST_NAME...]
set -u
build=${1:?usage: tests/run_tests.sh BUILD_DIR [TEST_NAME...]}
shift
cd "$(dirname "$0")/.."
# Our program cache in the build folder, so tests never touch the user's cache.
export SPECTRACE_CACHE_DIR=${SPECTRACE_CACHE_DIR:-$PWD/$build/cache}
export SPECTRACE_EXE=$PWD/$build/spectrace
# Sanitizer builds: PoCL and LLVM never free their compiler state, which
# LeakSanitizer reports at exit after a cold kernel compile; tests/lsan.supp
# suppresses leaks inside those libraries only (ours stay visible).
export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}
# The MPI tests run mpirun; as root in CI Open MPI needs these.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

if [ $# -gt 0 ]; then
  bins=(); for t in "$@"; do bins+=("$build/tests/$t"); done
else
  bins=("$build"/tests/test_*)
fi
passed=0; failed=0; skipped=0; failed_bins=()
for bin in "${bins[@]}"; do
  [ -x "$bin" ] || continue
  name=$(basename "$bin")
  echo "== $name"
  log=$(mktemp)
  start=$(date +%s)
  "$bin" 2>&1 | tee "$log"
  rc=${PIPESTATUS[0]}
  p=$(sed -n 's/^\[  PASSED  \] \([0-9]*\) test.*/\1/p' "$log" | awk '{s+=$1} END {print s+0}')
  f=$(sed -n 's/^\[  FAILED  \] \([0-9]*\) test.*/\1/p' "$log" | awk '{s+=$1} END {print s+0}')
  s=$(sed -n 's/^\[  SKIPPED \] \([0-9]*\) test.*/\1/p' "$log" | awk '{s+=$1} END {print s+0}')
  if [ "$rc" -ne 0 ] && [ "$f" -eq 0 ]; then f=1; fi
  echo "== $name: $p passed, $f failed, $s skipped ($(( $(date +%s) - start )) s)"
  passed=$((passed + p)); failed=$((failed + f)); skipped=$((skipped + s))
  [ "$f" -gt 0 ] && failed_bins+=("$name")
  rm -f "$log"
done
echo
[ ${#failed_bins[@]} -gt 0 ] && echo "failing: ${failed_bins[*]}"
echo "$passed passed, $failed failed, $skipped skipped"
[ "$failed" -eq 0 ]
