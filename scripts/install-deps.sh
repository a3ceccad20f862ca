#!/usr/bin/env bash
# Installs the Debian 12 packages haustra builds and tests with, and only those that are missing.
# Run as root, or as a user with sudo. Idempotent: a second run installs nothing.
set -euo pipefail

packages=(
  # toolchain
  g++ cmake ninja-build make pkg-config
  # the chosen dependency set (docs/decisions/0001-dependencies.md)
  libeigen3-dev libtbb-dev libembree-dev libassimp-dev libbenchmark-dev doctest-dev
  libtomlplusplus-dev nlohmann-json3-dev libcli11-dev libfmt-dev libpng-dev
  # instruction-count gate and sanitizer runtimes
  valgrind
  # the house style, checked by make test (.clang-format, scripts/check-format.sh)
  clang-format
  # the Python module (`make python`) and its tests and examples (decision 0043)
  python3-dev pybind11-dev python3-pybind11 python3-numpy python3-pytest python3-matplotlib
  # the stubs checked against the module and a typed example (decision 0080)
  python3-mypy
  # haustra.studies: studies on Dask, a local cluster or any scheduler (decision 0070)
  python3-dask python3-distributed
  # the Python API reference, made from the module's docstrings (`make reference`, decision 0101)
  python3-sphinx
  # `pip install .` into a virtual environment, offline (decision 0059)
  python3-venv python3-pip python3-setuptools python3-wheel
  # `haustra import` computes centrelines with CGAL (decision 0047)
  libcgal-dev
  # the viewer (`make view`, decision 0046) and its test under Xvfb with Mesa's software OpenGL
  libglfw3-dev libimgui-dev libgl-dev xvfb xauth xfonts-base libgl1-mesa-dri
  # the viewer's videos (V, `record` in a script): ffmpeg, and ffprobe for their test
  ffmpeg
)
for extra in "$@"; do
  case "$extra" in
    --figures) ;;                                          # `make figures`, `make soak`: matplotlib, now always in
    --fuzz) packages+=(clang libclang-rt-14-dev) ;;        # `make fuzz`: clang and its libFuzzer runtime
    --peers) packages+=(libbullet-dev libmujoco-dev) ;;    # `make bench-peers`: Bullet 3.24 and MuJoCo 2.2
    *) echo "install-deps: unknown option $extra (expected --figures, --fuzz or --peers)" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "install-deps: not root and no sudo; install: ${missing[*]}" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y --no-install-recommends "${missing[@]}"
