#!/usr/bin/env bash
# Sanitizer builds only: runs a test binary (the gtest targets' CROSSCOMPILING_EMULATOR, so every
# test of tests/CMakeLists.txt's gtest binaries goes through it) and runs it once more when it
# failed for one reason only: LeakSanitizer's own tracer crashed while it suspended the threads at
# exit ("Tracer caught signal", then "LeakSanitizer has encountered a fatal error"). That crash is
# the sanitizer runtime's, intermittent and known upstream (google/sanitizers#1353); it says
# nothing of the program, and no leak check ran. Any other failure stands: a failed assertion, a
# sanitizer report (AddressSanitizer, LeakSanitizer's "detected memory leaks", UBSan's "runtime
# error"), a crash of the test itself, or the tracer crashing twice. The retry is said in the
# output, and tests/sanitizers/lsan_tracer_retry_test.sh checks each case.
set -uo pipefail
[ $# -ge 1 ] || { echo "usage: $0 COMMAND [ARGS...]" >&2; exit 2; }

out=$(mktemp) || exit 2
trap 'rm -f "$out"' EXIT

run() {
  "$@" 2>&1 | tee "$out"
  return "${PIPESTATUS[0]}"
}

run "$@"
rc=$?
if [ "$rc" -ne 0 ] \
  && grep -q '^Tracer caught signal' "$out" \
  && grep -q 'LeakSanitizer has encountered a fatal error' "$out" \
  && ! grep -q -E 'ERROR: (AddressSanitizer|LeakSanitizer: detected)|runtime error:|\[  FAILED  \]' "$out"; then
  echo "lsan_tracer_retry: LeakSanitizer's tracer crashed at exit (exit $rc, no report of the program's); running the test once more"
  run "$@"
  rc=$?
fi
exit "$rc"
