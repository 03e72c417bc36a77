#!/usr/bin/env bash
# Installs every Debian package Nephele needs to build, test and render headless.
# Safe to run again: apt-get skips what is already installed.
set -euo pipefail
PKGS=(
  build-essential cmake pkg-config
  libegl-dev libegl-mesa0 libgl-dev libgl1-mesa-dri   # EGL + Mesa llvmpipe (headless default)
  libosmesa6-dev                                       # OSMesa fallback
  libglfw3-dev xvfb xauth                              # windows (nephele fly), tested under Xvfb
  libimgui-dev                                         # nephele fly's HUD (Dear ImGui, GLFW + OpenGL 3 backends)
  libglm-dev                                           # vector maths
  nlohmann-json3-dev                                   # scene files
  libcli11-dev                                         # command-line parsing
  libpng-dev                                           # PNG output
  libopenvdb-dev libboost-iostreams-dev                # nephele export --vdb (Debian's FindOpenVDB.cmake needs Boost iostreams)
  libgtest-dev googletest                              # tests
  python3-matplotlib                                   # bench charts (/usr/bin/python3)
  clang libclang-rt-14-dev                             # the libFuzzer harness (tests/fuzz/smoke.sh)
  doxygen                                              # the API reference (docs/api.md)
  clang-format                                         # the form gate (.clang-format, tools/check_format.py)
)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#PKGS[@]} packages already installed"
  exit 0
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
