#!/usr/bin/env bash
# Installs the build into a scratch prefix, then builds the C host example against it twice — with
# the plain cc line of the README and with find_package(haustra) — and runs it for 10 s of
# simulated time at 1 kHz with its haptic and render threads; imports the Python module from the prefix.
set -euo pipefail
build=$1 source=$2
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
cmake --install "$build" --prefix "$scratch/prefix" >/dev/null
prefix=$scratch/prefix
cc -std=c99 -Wall -Wextra -Werror "$source/tools/examples/haptic_host.c" -I"$prefix/include" -L"$prefix/lib" \
  -Wl,-rpath,"$prefix/lib" -lhaustra -lpthread -lm -o "$scratch/haptic_host"
cmake -S "$source/tools/examples" -B "$scratch/consumer" -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$scratch/consumer" >/dev/null
test -x "$scratch/consumer/haptic_host"
"$scratch/haptic_host" "$source/scenes/haptic-host.toml" 10
# The Python module, where the build has it: importable from the prefix's site-packages alone.
if [[ -d "$build/python/haustra" ]]; then
  site=$(echo "$prefix"/lib/python3*/site-packages)
  (cd "$scratch" && PYTHONPATH="$site" /usr/bin/python3 -c "
import haustra, sys
assert haustra.__file__.startswith('$site'), haustra.__file__
w = haustra.World.from_scene('$source/scenes/drop.toml')
w.step(3)
print('python module from the prefix:', w)")
fi
