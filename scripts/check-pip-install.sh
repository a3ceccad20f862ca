#!/bin/sh
# `pip install .` as a user does it, offline: a fresh virtual environment that sees Debian's
# setuptools, wheel and NumPy, the package built through the project's CMake (setup.py) in the
# given build tree, then imported from the environment (not the build tree) and stepped.
# Usage: check-pip-install.sh SOURCE_DIR BUILD_DIR HAUSTRA_CLI
set -eu
source_dir=$1 build_dir=$2 cli=$3
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
/usr/bin/python3 -m venv --system-site-packages "$scratch/venv"
unset PYTHONPATH
HAUSTRA_CMAKE_BUILD_DIR="$build_dir" "$scratch/venv/bin/pip" install --quiet --no-build-isolation --no-deps \
  --no-index "$source_dir"
cd "$scratch"
"$scratch/venv/bin/python" - "$source_dir" "$cli" "$scratch/venv" <<'PY'
import subprocess, sys
from importlib import metadata
import haustra
source, cli, venv = sys.argv[1:]
assert haustra.__file__.startswith(venv), f"imported {haustra.__file__}, not the environment's"
import pathlib
package = pathlib.Path(haustra.__file__).parent
missing = [f for f in ("py.typed", "_haustra.pyi", "types.py") if not (package / f).exists()]
assert not missing, f"the installed package lacks {missing}"
import haustra.studies  # the subpackage ships too (decision 0070)
assert haustra.studies.__file__.startswith(venv), f"imported {haustra.studies.__file__}, not the environment's"
cli_version = subprocess.run([cli, "--version"], capture_output=True, text=True, check=True).stdout.split()[-1]
assert haustra.__version__ == cli_version == metadata.version("haustra"), (haustra.__version__, cli_version)
w = haustra.World.from_scene(f"{source}/scenes/cantilever.toml")
recording = w.step(5, record=["node_positions"])
assert w.frame == 5 and recording["node_positions"].shape == (5, w.node_count, 3)
print(f"pip install .: haustra {haustra.__version__} from {haustra.__file__}, stepped 5 frames")
PY
