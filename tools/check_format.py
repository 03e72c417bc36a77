#!/usr/bin/env python3
# The form gate (issue #36 §8; docs/testing.md, "Form checks"): every C++ file of the project is
# as clang-format 14 writes it with the repository's .clang-format, and every shader line is at
# most 120 columns (clang-format has no GLSL: the shaders keep the C++ layout by hand).
#
#   tools/check_format.py ROOT           check; exit 1 listing each file that differs
#   tools/check_format.py ROOT --fix     rewrite the C++ files in place (clang-format -i)
#
# The files are git's tracked ones when ROOT is a checkout's top, else every file under it but
# build trees (a copy of the tree inside another checkout, as the sabotage runner makes); none at
# all fails. clang-format's output differs between major versions, so only version 14 (Debian
# bookworm's, what setup.sh installs) is the house style: with another one the check exits 77
# (ctest: skipped) saying so, and CI, which has 14, runs it for real.
import os
import re
import shutil
import subprocess
import sys

CXX = (".cpp", ".hpp", ".h")
SHADER = (".glsl", ".vert", ".frag", ".comp", ".geom")
COLUMNS = 120
SKIP_DIRS = {".git", "bench-out"}
WANTED_MAJOR = 14


def source_files(root):
    try:  # git's list, when ROOT is a checkout's top (not a copy inside another checkout)
        top = subprocess.run(["git", "-C", root, "rev-parse", "--show-toplevel"], check=True, capture_output=True)
        if os.path.realpath(top.stdout.decode().strip()) != os.path.realpath(root):
            raise ValueError("not the top of a checkout")
        out = subprocess.run(["git", "-C", root, "ls-files", "-z"], check=True, capture_output=True).stdout
        return sorted(p for p in out.decode().split("\0") if p)
    except (OSError, ValueError, subprocess.CalledProcessError):
        files = []
        for d, dirs, names in os.walk(root):
            dirs[:] = [x for x in dirs if x not in SKIP_DIRS and not x.startswith("build")]
            files += [os.path.relpath(os.path.join(d, n), root) for n in names]
        return sorted(files)


def find_clang_format():
    seen = []
    for name in (f"clang-format-{WANTED_MAJOR}", "clang-format"):
        exe = shutil.which(name)
        if not exe:
            continue
        text = subprocess.run([exe, "--version"], capture_output=True, text=True).stdout.strip()
        m = re.search(r"version (\d+)\.", text)
        if m and int(m.group(1)) == WANTED_MAJOR:
            return exe, ""
        seen.append(f"{exe} is '{text}'")
    return None, "; ".join(seen) or "there is no clang-format on PATH"


def main():
    if len(sys.argv) not in (2, 3) or (len(sys.argv) == 3 and sys.argv[2] != "--fix"):
        print("usage: check_format.py ROOT [--fix]", file=sys.stderr)
        return 2
    root, fix = sys.argv[1], len(sys.argv) == 3
    files = source_files(root)
    cxx = [f for f in files if f.endswith(CXX) and not f.startswith("tests/fuzz/corpus")]
    shaders = [f for f in files if f.endswith(SHADER)]
    if not cxx:
        print(f"check_format: no C++ file under {root}: not the project's root?")
        return 1
    exe, why = find_clang_format()
    if not exe:
        print(f"check_format: skipped: the house style is clang-format {WANTED_MAJOR}'s, and {why} "
              "(setup.sh installs Debian's clang-format)")
        return 77
    bad = []
    for i in range(0, len(cxx), 64):
        batch = [os.path.join(root, f) for f in cxx[i:i + 64]]
        args = [exe, "--style=file"] + (["-i"] if fix else ["--dry-run", "--Werror"])
        r = subprocess.run(args + batch, capture_output=True, text=True)
        if fix and r.returncode != 0:
            print(r.stderr, file=sys.stderr)
            return 1
        bad += sorted({os.path.relpath(m, root) for m in re.findall(r"^(\S+?):\d+:\d+: error:", r.stderr, re.M)})
    long_lines = []
    for f in shaders:
        with open(os.path.join(root, f), encoding="utf-8") as fh:
            for n, line in enumerate(fh, 1):
                if len(line.rstrip("\n")) > COLUMNS:
                    long_lines.append(f"{f}:{n}: {len(line.rstrip())} columns, at most {COLUMNS}")
    for f in bad:
        print(f"{f}: not as clang-format writes it (see: clang-format --style=file {f} | diff {f} -)")
    for line in long_lines:
        print(line)
    if bad or long_lines:
        print(f"check_format: {len(bad)} of {len(cxx)} C++ files to reformat "
              "(cmake --build build --target format), "
              f"{len(long_lines)} shader lines over {COLUMNS} columns")
        return 1
    print(f"check_format: {len(cxx)} C++ files as clang-format {WANTED_MAJOR} writes them, "
          f"{len(shaders)} shaders within {COLUMNS} columns")
    return 0


if __name__ == "__main__":
    sys.exit(main())
