#!/usr/bin/env bash
# The fuzz smoke: builds the libFuzzer targets of the input readers (clang, ASan + UBSan) and
# runs each on the kept corpus (tests/fuzz/corpus/) and the shipped scenes, meshes and images
# for SECONDS (default 20; the five targets at once; CI gives 10). Exits non-zero on a crash, a
# sanitizer report, a timeout or an out-of-memory, leaving the input in BUILD/fuzz-artifacts/.
#   tests/fuzz/smoke.sh [SECONDS] [BUILD]     (BUILD default: build-fuzz in the checkout)
# New inputs go to a temporary folder: the kept corpus changes only by hand (see docs/testing.md).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
seconds=${1:-20}
build=${2:-$root/build-fuzz}
launcher=()
if command -v ccache >/dev/null; then
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DNEPHELE_FUZZ=ON -DNEPHELE_BUILD_TESTS=OFF \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DNEPHELE_UNITY_LIBRARIES=ON "${launcher[@]}" >/dev/null
cmake --build "$build" -j2 --target nephele_fuzz_scene nephele_fuzz_obj nephele_fuzz_png nephele_fuzz_flight nephele_fuzz_cigi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
artifacts="$build/fuzz-artifacts"
mkdir -p "$artifacts"
declare -A seeds=(
  [scene]="$root/data/scenes $root/tests/data/scenes"
  [obj]="$root/data/meshes $root/tests/data"
  [png]="$root/tests/golden"
  [flight]="$root/data/flights"
  [cigi]=""
)
# The five run at once (the machine's cores shared between them: CI's minute is a minute, not
# five), each with its own log and exit status.
targets=(scene obj png flight cigi)
for target in "${targets[@]}"; do
  mkdir -p "$work/$target"
  echo "fuzz smoke: $target for ${seconds} s"
  # -timeout: one input over 30 s is a hang (wall time, with five sharing the cores: the slowest
  # kept input, a 44,000-ellipsoid cumulus, takes about 4 s alone); -rss_limit_mb: more than
  # 2 GB is runaway memory.
  # shellcheck disable=SC2086
  ( set +e
    "$build/bin/nephele_fuzz_$target" -max_total_time="$seconds" -timeout=30 -rss_limit_mb=2048 \
      -print_final_stats=1 -artifact_prefix="$artifacts/$target-" \
      "$work/$target" "$here/corpus/$target" ${seeds[$target]} >"$work/$target.log" 2>&1
    echo $? >"$work/$target.status" ) &
done
wait
failed=0
for target in "${targets[@]}"; do
  status=$(cat "$work/$target.status")
  echo "fuzz smoke: $target: $(grep -E "^stat::number_of_executed_units" "$work/$target.log" || echo 'no stats')"
  if [ "$status" -ne 0 ]; then
    tail -n 60 "$work/$target.log" >&2
    echo "fuzz smoke: $target FAILED (exit $status); the input is in $artifacts/" >&2
    failed=1
  fi
done
[ "$failed" = 0 ] || exit 1
echo "fuzz smoke: passed"
