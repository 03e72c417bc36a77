#!/usr/bin/env bash
# Copies build/test-output/NAME[_TAG]_actual.png to tests/golden/NAME.png, after a person
# has looked at the actual image side by side with the current golden.
# Usage: tests/promote_golden.sh NAME [TAG]      (BUILD_DIR=build by default)
set -euo pipefail
name=${1:?usage: tests/promote_golden.sh NAME [TAG]}
tag=${2:+_$2}
build=${BUILD_DIR:-build}
here=$(cd "$(dirname "$0")" && pwd)
src="$build/test-output/${name}${tag}_actual.png"
[ -f "$src" ] || { echo "promote_golden: no $src (run the test first)" >&2; exit 2; }
cp "$src" "$here/golden/$name.png"
echo "promote_golden: $src -> tests/golden/$name.png"
