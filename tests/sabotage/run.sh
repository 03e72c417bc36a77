#!/usr/bin/env bash
# The sabotage check (issue #39, docs/testing.md): each tests/sabotage/*.sabotage file breaks one
# or a few source lines the way a real bug would, and names the test that must then fail. This
# script applies them one at a time to a scratch copy of the tracked tree (the checkout itself is
# never written), rebuilds only the test executables, runs the named test and reports
#   CAUGHT    the test failed on the broken build (what we want),
#   SURVIVED  the test passed: it cannot see this breakage,
#   ERROR     the patch is malformed, does not apply, does not build, or its test fails unbroken.
# Exit 0 only if every patch was caught.
#
# Usage: tests/sabotage/run.sh [--filter REGEX] [--keep] [--survivors] [--workdir DIR]
#                              [--timeout SECONDS] [--jobs N] [--check]
#   --filter REGEX   only the patch files whose name matches REGEX (grep -E)
#   --keep           keep the scratch copy and its build (the path is printed)
#   --survivors      also run the *.survives files: patches a test is known not to catch today
#   --workdir DIR    where the scratch copy and the logs go (default: build-sabotage/ in the
#                    checkout, ignored by git). The copy's path is fixed so that ccache serves
#                    the next run every object this one compiled.
#   --timeout SEC    bound of each test run (default 900; a run that hits it counts as caught
#                    only when the unbroken run took less than a third of it, else as an error)
#   --jobs N         build parallelism (default 2)
#   --check          only parse the patch files and look their find: lines up; build nothing
set -uo pipefail
# The whole script is one block, read before it runs: editing this file (or pulling) while a
# run is under way does not change that run.
{

die() { echo "sabotage: $*" >&2; exit 2; }

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(git -C "$script_dir" rev-parse --show-toplevel 2>/dev/null) || die "not inside a git checkout: $script_dir"

filter='' keep=0 survivors=0 workdir="$repo/build-sabotage" test_timeout=900 jobs=2 check_only=0
while (($#)); do
  case $1 in
    --filter) (($# >= 2)) || die "--filter needs a regular expression"; filter=$2; shift 2 ;;
    --keep) keep=1; shift ;;
    --survivors) survivors=1; shift ;;
    --workdir) (($# >= 2)) || die "--workdir needs a directory"; workdir=$2; shift 2 ;;
    --timeout) [[ ${2-} =~ ^[1-9][0-9]*$ ]] || die "--timeout needs a whole number of seconds, got '${2-}'"
               test_timeout=$2; shift 2 ;;
    --jobs) [[ ${2-} =~ ^[1-9][0-9]?$ ]] || die "--jobs needs a number from 1 to 99, got '${2-}'"; jobs=$2; shift 2 ;;
    --check) check_only=1; shift ;;
    -h|--help) sed -n '2,/^set -uo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown argument '$1' (see --help)" ;;
  esac
done
if [[ -n $filter ]]; then
  echo '' | grep -Eq -- "$filter" 2>/dev/null; (($? == 2)) && die "--filter: '$filter' is not a valid regular expression"
fi

# ---------------------------------------------------------------------------------------------
# The patch files: strict parsing. A file is
#   # comment lines (at least one, before test:)
#   test: <ctest -R regex>
#   file: <path from the repo root>
#   find: <one exact source line, leading/trailing whitespace ignored, unique in that file>
#   replace: <the broken line>
#   (more find:/replace: pairs)
# Blank lines and further comment lines may appear anywhere after the first comment.
trim() { TRIMMED=$1; TRIMMED=${TRIMMED#"${TRIMMED%%[![:space:]]*}"}; TRIMMED=${TRIMMED%"${TRIMMED##*[![:space:]]}"}; }

# parse FILE: sets P_TEST, P_FILE, P_FINDS[], P_REPLACES[]; on error sets ERR="FILE:LINE: why", returns 1.
parse_patch() {
  local f=$1 n=0 line key value seen_comment=0 pending_find=0 pending_line=0
  P_TEST='' P_FILE='' P_FINDS=() P_REPLACES=()
  local name; name=$(basename "$f")
  while IFS= read -r line || [[ -n $line ]]; do
    n=$((n + 1))
    line=${line%$'\r'}
    if [[ $line =~ ^[[:space:]]*# ]]; then seen_comment=1; continue; fi
    trim "$line"; [[ -n $TRIMMED ]] || continue
    if ((!seen_comment)); then ERR="$name:$n: the file must start with comment lines saying what is broken and which test must catch it"; return 1; fi
    if [[ ! $line =~ ^(test|file|find|replace):(.*)$ ]]; then
      ERR="$name:$n: expected 'test:', 'file:', 'find:' or 'replace:', got: $line"; return 1
    fi
    key=${BASH_REMATCH[1]}; trim "${BASH_REMATCH[2]}"; value=$TRIMMED
    case $key in
      test)
        [[ -z $P_TEST ]] || { ERR="$name:$n: a second 'test:' line"; return 1; }
        [[ -n $value ]] || { ERR="$name:$n: 'test:' is empty"; return 1; }
        echo '' | grep -Eq -- "$value" 2>/dev/null; (($? == 2)) && { ERR="$name:$n: 'test:' is not a valid regular expression: $value"; return 1; }
        P_TEST=$value ;;
      file)
        [[ -n $P_TEST ]] || { ERR="$name:$n: 'file:' before 'test:'"; return 1; }
        [[ -z $P_FILE ]] || { ERR="$name:$n: a second 'file:' line (one file per patch)"; return 1; }
        [[ -n $value ]] || { ERR="$name:$n: 'file:' is empty"; return 1; }
        [[ $value != /* && $value != *..* ]] || { ERR="$name:$n: 'file:' must be a path inside the repository: $value"; return 1; }
        P_FILE=$value ;;
      find)
        [[ -n $P_FILE ]] || { ERR="$name:$n: 'find:' before 'file:'"; return 1; }
        ((!pending_find)) || { ERR="$name:$n: 'find:' after 'find:' on line $pending_line without its 'replace:'"; return 1; }
        [[ -n $value ]] || { ERR="$name:$n: 'find:' is empty"; return 1; }
        P_FINDS+=("$value"); pending_find=1; pending_line=$n ;;
      replace)
        ((pending_find)) || { ERR="$name:$n: 'replace:' without a 'find:' before it"; return 1; }
        [[ $value != "${P_FINDS[-1]}" ]] || { ERR="$name:$n: 'replace:' is the same as its 'find:' (breaks nothing)"; return 1; }
        P_REPLACES+=("$value"); pending_find=0 ;;
    esac
  done < "$f"
  ((pending_find)) && { ERR="$name:$pending_line: 'find:' without a 'replace:'"; return 1; }
  [[ -n $P_TEST ]] || { ERR="$name:$n: no 'test:' line"; return 1; }
  [[ -n $P_FILE ]] || { ERR="$name:$n: no 'file:' line"; return 1; }
  ((${#P_FINDS[@]})) || { ERR="$name:$n: no 'find:'/'replace:' pair"; return 1; }
  return 0
}

# Line numbers (1-based) of FILE whose text, leading and trailing whitespace removed, is TEXT.
matching_lines() {
  FIND_TEXT=$2 awk '{ l = $0; sub(/\r$/, "", l); gsub(/^[ \t\f\v]+|[ \t\f\v]+$/, "", l)
                      if (l == ENVIRON["FIND_TEXT"]) print NR }' "$1"
}

# resolve_target ROOT NAME: sets R_FILE, the file (relative to ROOT, the tracked tree) the parsed
# patch applies to, and checks each find: line is in it exactly once; else sets ERR to why.
# grep -F first, so that the slow line-by-line comparison only runs on files that can match.
resolve_target() {
  local root=$1 name=$2 i cand=()
  R_FILE=''
  if [[ -f $root/$P_FILE ]]; then
    R_FILE=$P_FILE
  else
    # The file has moved (files are being reorganised): the one tracked file holding every find: line.
    local f ok
    while IFS= read -r f; do
      ok=1
      for i in "${!P_FINDS[@]}"; do
        [[ -n $(matching_lines "$root/$f" "${P_FINDS[$i]}") ]] || { ok=0; break; }
      done
      ((ok)) && cand+=("$f")
    done < <(cd "$root" && tr '\n' '\0' < "$tracked_list" | xargs -0 grep -lF -- "${P_FINDS[0]}" 2>/dev/null)
    if ((${#cand[@]} == 0)); then
      ERR="$name: file: $P_FILE does not exist and no tracked file holds its find: line(s)"; return 1
    elif ((${#cand[@]} > 1)); then
      ERR="$name: file: $P_FILE does not exist and ${#cand[@]} tracked files hold its find: line(s): ${cand[*]}"; return 1
    fi
    R_FILE=${cand[0]}
  fi
  for i in "${!P_FINDS[@]}"; do
    local hits; hits=$(matching_lines "$root/$R_FILE" "${P_FINDS[$i]}" | wc -l)
    if ((hits != 1)); then
      local ln; ln=$(grep -n -m1 -F -- "find: ${P_FINDS[$i]}" "$patch_path" | cut -d: -f1)
      if ((hits == 0)); then ERR="$name:${ln:-?}: find: line not in $R_FILE: ${P_FINDS[$i]}"
      else ERR="$name:${ln:-?}: find: line is in $R_FILE $hits times (it must be unique): ${P_FINDS[$i]}"; fi
      return 1
    fi
  done
  return 0
}

# Writes the broken version of ROOT/R_FILE (each found line replaced, its indentation kept).
apply_patch() {
  local target=$1 i lines=() idx l
  mapfile -t lines < "$target"
  for i in "${!P_FINDS[@]}"; do
    idx=$(matching_lines "$target" "${P_FINDS[$i]}")
    [[ -n $idx ]] || return 1
    l=${lines[idx - 1]}
    lines[idx - 1]="${l%%[![:space:]]*}${P_REPLACES[$i]}"
    printf '%s\n' "${lines[@]}" > "$target"
  done
}

# ---------------------------------------------------------------------------------------------
mkdir -p "$workdir" || die "cannot create the work directory $workdir"
workdir=$(cd "$workdir" && pwd)
tracked_list=$workdir/tracked.txt
git -C "$repo" ls-files -z | tr '\0' '\n' | while IFS= read -r f; do [[ -f $repo/$f && ! -L $repo/$f ]] && echo "$f"; done > "$tracked_list"

patches=()
for f in "$repo"/tests/sabotage/*.sabotage; do [[ -e $f ]] && patches+=("$f"); done
if ((survivors)); then for f in "$repo"/tests/sabotage/*.survives; do [[ -e $f ]] && patches+=("$f"); done; fi
if [[ -n $filter ]]; then
  kept=(); for f in "${patches[@]}"; do basename "$f" | grep -Eq -- "$filter" && kept+=("$f"); done; patches=("${kept[@]}")
fi
IFS=$'\n' patches=($(printf '%s\n' "${patches[@]}" | sort)); unset IFS
((${#patches[@]})) || die "no patch files matched in $repo/tests/sabotage"

start=$(date +%s)
passed=0 failed=0
declare -A status reason patch_test patch_file
ok_patches=()

# Parse and resolve every patch against the checkout's tracked tree before building anything.
for patch_path in "${patches[@]}"; do
  name=$(basename "$patch_path")
  if ! parse_patch "$patch_path"; then status[$name]=ERROR reason[$name]=$ERR; continue; fi
  if ! resolve_target "$repo" "$name"; then status[$name]=ERROR reason[$name]=$ERR; continue; fi
  patch_test[$name]=$P_TEST patch_file[$name]=$R_FILE
  ok_patches+=("$patch_path")
done

report() { # name status detail
  printf '%-9s %-50s %s\n' "$2" "$1" "$3"
}
finish() {
  for patch_path in "${patches[@]}"; do
    name=$(basename "$patch_path")
    [[ ${status[$name]-} == CAUGHT ]] && passed=$((passed + 1)) || failed=$((failed + 1))
  done
  local wall=$(( $(date +%s) - start ))
  echo "wall time $((wall / 60)) min $((wall % 60)) s; logs in $workdir/logs"
  echo "$passed passed, $failed failed"
  ((failed == 0))
}

if ((check_only)); then
  for patch_path in "${patches[@]}"; do
    name=$(basename "$patch_path")
    if [[ ${status[$name]-} == ERROR ]]; then report "$name" ERROR "${reason[$name]}"
    else report "$name" OK "${patch_test[$name]} in ${patch_file[$name]}"; fi
  done
  errors=0; for n in "${status[@]}"; do errors=$((errors + 1)); done
  echo "check: $(( ${#patches[@]} - errors )) patches parse and apply, $errors do not"
  ((errors == 0)); exit $?
fi

# ---------------------------------------------------------------------------------------------
# The scratch copy: the tracked files as they are in the checkout (uncommitted edits included).
# Its path is fixed (<workdir>/scratch, made afresh each run) and its build is <copy>/build, the
# usual layout, so that ccache (base_dir) serves every unchanged object from the last run. The
# precompiled headers are off in it: ccache cannot cache what is compiled with them.
exec 9> "$workdir/lock"
flock -n 9 || die "another sabotage run is using $workdir"
mkdir -p "$workdir/logs" && rm -f "$workdir"/logs/*.log
scratch=$workdir/scratch
rm -rf "$scratch" && mkdir -p "$scratch" || die "cannot create the scratch directory $scratch"
cleanup() {
  if ((keep)); then echo "scratch copy kept: $scratch"; else rm -rf "$scratch"; fi
}
trap cleanup EXIT
trap 'echo "sabotage: interrupted" >&2; exit 130' INT TERM
(cd "$repo" && tr '\n' '\0' < "$tracked_list" | tar --null -T - -cf -) | (cd "$scratch" && tar -xf -) \
  || die "copying the tracked tree to $scratch failed"
build=$scratch/build

launcher=()
if command -v ccache >/dev/null; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache); fi
echo "scratch copy $scratch; configuring and building (-j$jobs)"
if ! cmake -S "$scratch" -B "$build" "${launcher[@]}" -DNEPHELE_PCH=OFF -DNEPHELE_SABOTAGE=OFF > "$workdir/logs/configure.log" 2>&1; then
  tail -20 "$workdir/logs/configure.log"; die "configuring the scratch copy failed (log: $workdir/logs/configure.log)"
fi

# Which test executable runs which ctest name, from ctest's own listing of the unbroken build.
test_targets=$(sed -n 's/^[[:space:]]*add_executable(\([A-Za-z0-9_]*\) .*/\1/p' "$scratch/tests/CMakeLists.txt" | tr '\n' ' ')
[[ -n $test_targets ]] || die "found no add_executable() in tests/CMakeLists.txt"
# shellcheck disable=SC2086
if ! cmake --build "$build" -j"$jobs" --target $test_targets > "$workdir/logs/build.log" 2>&1; then
  tail -30 "$workdir/logs/build.log"; die "the unbroken scratch build failed (log: $workdir/logs/build.log)"
fi
declare -A test_of_exe
names_file=$workdir/test-names.txt; : > "$names_file"
for t in $test_targets; do
  exe=$build/bin/$t
  [[ -x $exe ]] || die "test executable $exe missing after the build"
  "$exe" --gtest_list_tests 2>/dev/null | awk -v t="$t" '
    /^[^ ]/ { suite = $1; next }
    /^  / { print t " " suite $1 }' >> "$names_file"
done
echo "built in $(( $(date +%s) - start )) s; $(wc -l < "$names_file") tests"

targets_for() { # the executables holding a test matched by the regex; "none" for a ctest test of no executable (LayoutCheck)
  local t; t=$(RE=$1 awk '$2 ~ ENVIRON["RE"] { print $1 }' "$names_file" | sort -u | tr '\n' ' ')
  if [[ -z $t ]] && (cd "$build" && ctest -N -R "$1" 2>/dev/null | grep -q '^Total Tests: [1-9]'); then t=none; fi
  echo "$t"
}
run_test() { # regex log -> sets RT_RC (0 passed, 1 failed, 2 skipped, 124 timeout) and RT_SECONDS
  local t0; t0=$(date +%s)
  (cd "$build" && timeout -k 30 "$test_timeout" ctest -R "$1" -V --timeout "$test_timeout") > "$2" 2>&1
  local rc=$?
  RT_SECONDS=$(( $(date +%s) - t0 ))
  if ((rc == 124 || rc == 137)) || grep -q '\*\*\*Timeout' "$2"; then RT_RC=124
  elif grep -q ' (Skipped)$' "$2"; then RT_RC=2  # a skipped test passes whatever the patch does
  elif ((rc == 0)) && grep -q 'tests passed, 0 tests failed' "$2"; then RT_RC=0
  else RT_RC=1; fi
}

# Each named test must pass unbroken, or a failure on the broken build would mean nothing.
declare -A base_rc base_seconds
for patch_path in "${ok_patches[@]}"; do
  name=$(basename "$patch_path"); re=${patch_test[$name]}
  [[ -n ${base_rc[$re]-} ]] && continue
  targets=$(targets_for "$re")
  if [[ -z $targets ]]; then base_rc[$re]=none; continue; fi
  run_test "$re" "$workdir/logs/unbroken-${name%.*}.log"
  base_rc[$re]=$RT_RC base_seconds[$re]=$RT_SECONDS
done

for patch_path in "${patches[@]}"; do
  name=$(basename "$patch_path")
  if [[ ${status[$name]-} == ERROR ]]; then report "$name" ERROR "${reason[$name]}"; continue; fi
  re=${patch_test[$name]} rel=${patch_file[$name]}
  case ${base_rc[$re]} in
    none) # Name the tests that hold the regex's longest word (parameterised tests carry a prefix/suffix).
          word=$(grep -oE '[A-Za-z0-9_]+' <<< "$re" | awk '{ print length, $0 }' | sort -rn | head -1 | cut -d' ' -f2)
          like=$(awk -v w="$word" 'index($2, w) { print $2 }' "$names_file" | head -3 | tr '\n' ' ')
          status[$name]=ERROR; report "$name" ERROR "test: $re matches no test of the build${like:+ (names holding $word: $like)}"; continue ;;
    124) status[$name]=ERROR; report "$name" ERROR "$re timed out unbroken (${test_timeout} s)"; continue ;;
    1) status[$name]=ERROR; report "$name" ERROR "$re fails unbroken (log: logs/unbroken-${name%.*}.log)"; continue ;;
    2) status[$name]=ERROR; report "$name" ERROR "$re is skipped (the window tests need a display: run under xvfb-run -a)"; continue ;;
  esac
  parse_patch "$patch_path"
  log=$workdir/logs/${name%.*}.log
  target=$scratch/$rel saved=$workdir/original.tmp
  cp "$target" "$saved"
  if ! apply_patch "$target"; then
    cat "$saved" > "$target"; status[$name]=ERROR; report "$name" ERROR "could not apply to $rel"; continue
  fi
  targets=$(targets_for "$re")
  build_ok=1
  if [[ $targets == none ]]; then
    : > "$log"  # a test of the sources themselves (LayoutCheck): nothing to build
  else
    # shellcheck disable=SC2086
    cmake --build "$build" -j"$jobs" --target $targets > "$log" 2>&1 || build_ok=0
  fi
  if ((!build_ok)); then
    status[$name]=ERROR; report "$name" ERROR "the broken build does not compile (log: logs/${name%.*}.log)"
  else
    run_test "$re" "$log.test"
    cat "$log.test" >> "$log"; rm -f "$log.test"
    if ((RT_RC != 0)) && grep -Eq 'shader [^ ]+ failed to compile|program .* failed to link' "$log"; then
      # A shader that no longer compiles fails every GL test: that says nothing about the test.
      status[$name]=ERROR; report "$name" ERROR "a shader does not compile on the broken build (log: logs/${name%.*}.log)"
    elif ((RT_RC == 1)); then
      status[$name]=CAUGHT; report "$name" CAUGHT "$re (${RT_SECONDS} s)"
    elif ((RT_RC == 124)); then
      if (( ${base_seconds[$re]} * 3 < test_timeout )); then
        status[$name]=CAUGHT; report "$name" CAUGHT "$re (timed out at ${test_timeout} s; unbroken ${base_seconds[$re]} s)"
      else
        status[$name]=ERROR; report "$name" ERROR "$re timed out; unbroken it took ${base_seconds[$re]} s, raise --timeout"
      fi
    else
      status[$name]=SURVIVED; report "$name" SURVIVED "$re passed on the broken build (${RT_SECONDS} s)"
    fi
  fi
  # Restore with a fresh modification time, so that the next build compiles the original again.
  cat "$saved" > "$target"; rm -f "$saved"
done

finish
exit $?
}
