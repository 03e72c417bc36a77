#!/usr/bin/env bash
# Checks lsan_tracer_retry.sh with stand-in programs: it retries once the tracer's own crash and
# nothing else. Each case names what it expects; the first one that differs fails the test.
set -uo pipefail
retry="$(dirname "$0")/lsan_tracer_retry.sh"
work=$(mktemp -d) || exit 2
trap 'rm -rf "$work"' EXIT
failures=0

# A stand-in program: prints the given text, then exits with the given code; with a third
# argument, it does so only on its first run (later runs print "second run" and pass).
cat > "$work/fake.sh" <<'EOF'
#!/usr/bin/env bash
marker=$3
if [ -n "$marker" ] && [ -e "$marker" ]; then echo "second run"; exit 0; fi
[ -n "$marker" ] && touch "$marker"
printf '%b\n' "$1"
exit "$2"
EOF
chmod +x "$work/fake.sh"

tracer='[  PASSED  ] 1 test.\nTracer caught signal 11: addr=0x1528 pc=0x5574f194bd8a sp=0x7fa4cd53cd40\n==7458==LeakSanitizer has encountered a fatal error.'

expect() {  # NAME WANTED_RC WANTED_RUNS TEXT RC
  local name=$1 wanted=$2 runs=$3 text=$4 code=$5 marker="$work/$1.ran"
  local output rc got_runs
  output=$("$retry" "$work/fake.sh" "$text" "$code" "$marker")
  rc=$?
  got_runs=1
  grep -q 'second run' <<<"$output" && got_runs=2
  if [ "$rc" -ne "$wanted" ] || [ "$got_runs" -ne "$runs" ]; then
    echo "FAIL $name: exit $rc after $got_runs run(s), expected exit $wanted after $runs"
    failures=$((failures + 1))
  else
    echo "ok   $name: exit $rc after $got_runs run(s)"
  fi
}

expect tracer_crash_is_retried 0 2 "$tracer" 134
expect a_pass_is_not_run_again 0 1 "[  PASSED  ] 1 test." 0
expect a_failed_test_stands 1 1 "[  FAILED  ] 1 test, listed below:" 1
expect a_leak_report_stands 23 1 "==1==ERROR: LeakSanitizer: detected memory leaks\n$tracer" 23
expect an_asan_report_stands 134 1 "==1==ERROR: AddressSanitizer: heap-use-after-free\n$tracer" 134
expect a_ubsan_report_stands 134 1 "x.cpp:3:5: runtime error: signed integer overflow\n$tracer" 134
expect a_failed_assertion_with_a_tracer_crash_stands 134 1 "[  FAILED  ] A.B\n$tracer" 134
expect a_crash_without_the_tracer_line_stands 139 1 "Segmentation fault" 139

# Twice in a row: the second failure stands (no third run).
rm -f "$work/twice.ran"
"$retry" "$work/fake.sh" "$tracer" 134 "" > "$work/twice.out"
rc=$?
runs=$(grep -c '^Tracer caught signal' "$work/twice.out")
if [ "$rc" -ne 134 ] || [ "$runs" -ne 2 ]; then
  echo "FAIL the_tracer_crashing_twice_stands: exit $rc after $runs run(s), expected exit 134 after 2"
  failures=$((failures + 1))
else
  echo "ok   the_tracer_crashing_twice_stands: exit $rc after $runs run(s)"
fi

[ "$failures" -eq 0 ]
