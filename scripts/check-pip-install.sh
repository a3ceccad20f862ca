#!/bin/sh
# `pip install .` as the README says it, offline (decisions 0059, 0101): a fresh virtual environment
# made by Debian's python3 that sees Debian's setuptools, wheel and NumPy; the package built by
# setup.py, which reuses the release tree BUILD_DIR (already built by `make test`: nothing new is
# compiled); then imported from the environment (not the build tree), stepped, state written, a batch
# stepped, and its `haustra` command run. And an environment without Debian's packages: refused with setup.py's paragraph, not a
# pip traceback.
# Usage: check-pip-install.sh SOURCE_DIR BUILD_DIR HAUSTRA_CLI
set -eu
source_dir=$1 build_dir=$2 cli=$3
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
unset PYTHONPATH HAUSTRA_CMAKE_BUILD_DIR HAUSTRA_BIN
if [ "$(readlink -f "$build_dir")" != "$(readlink -f "$source_dir/build/release")" ]; then
  export HAUSTRA_CMAKE_BUILD_DIR="$build_dir"  # another tree than the one setup.py reuses by itself
fi
started=$(date +%s)
# The README's command, word for word but for the folder and --no-index (nothing is downloaded anyway).
cd "$scratch"
/usr/bin/python3 -m venv --system-site-packages .venv && .venv/bin/pip install --quiet --no-index --no-build-isolation "$source_dir"
echo "pip install .: $(($(date +%s) - started)) s (the environment made and the package installed from the built tree)"
"$scratch/.venv/bin/python" - "$source_dir" "$cli" "$scratch/.venv" <<'PY'
import subprocess, sys
from importlib import metadata
import haustra
source, cli, venv = sys.argv[1:]
assert haustra.__file__.startswith(venv), f"imported {haustra.__file__}, not the environment's"
import pathlib
package = pathlib.Path(haustra.__file__).parent
missing = [f for f in ("py.typed", "_haustra.pyi", "types.py", "bin/haustra") if not (package / f).exists()]
assert not missing, f"the installed package lacks {missing}"
import haustra.studies  # the subpackage ships too (decision 0070)
assert haustra.studies.__file__.startswith(venv), f"imported {haustra.studies.__file__}, not the environment's"
from haustra.studies.cells import haustra_command
assert haustra_command().startswith(venv), haustra_command()  # the studies' imports run the package's command
cli_version = subprocess.run([cli, "--version"], capture_output=True, text=True, check=True).stdout.split()[-1]
command = subprocess.run([f"{venv}/bin/haustra", "--version"], capture_output=True, text=True, check=True)
assert haustra.__version__ == cli_version == metadata.version("haustra") == command.stdout.split()[-1], \
    (haustra.__version__, cli_version, command.stdout)
run = subprocess.run([f"{venv}/bin/haustra", "run", f"{source}/scenes/cantilever.toml", "--frames", "5", "--quiet"],
                     capture_output=True, text=True)
assert run.returncode == 0, run.stderr
w = haustra.World.from_scene(f"{source}/scenes/cantilever.toml")
recording = w.step(5, record=["node_positions"])
assert w.frame == 5 and recording["node_positions"].shape == (5, w.node_count, 3)
# What the installed module adds to stepping (decisions 0102, 0103): state written from arrays, loads on many nodes and
# per metre, and a batch of worlds on 2 threads that gives each world's bits as a loop does.
import copy
import numpy as np
w.set_strains(0.5 * np.asarray(w.strains))
w.set_node_positions(np.array(w.node_positions))
w.set_external_loads([10, -1], [[0.0, 1e-4, 0.0], [0.0, 0.0, -1e-4]], add=True)
w.set_distributed_load(0, [0.0, 1e-4, 0.0])
alone = [copy.deepcopy(w) for _ in range(3)]
for k, a in enumerate(alone):
    a.add_external_load(-1, [0.0, 0.0, -1e-5 * k])
batched = [copy.deepcopy(a) for a in alone]
for a in alone:
    a.step(5)
haustra.Batch(batched, threads=2).step(5)
assert all(np.array(a.node_positions).tobytes() == np.array(b.node_positions).tobytes() for a, b in zip(alone, batched))
print(f"pip install .: haustra {haustra.__version__} from {haustra.__file__}, stepped 5 frames, state written, "
      f"3 worlds batched on 2 threads as stepped alone; the haustra command {command.stdout.strip()}")
PY
# An interpreter without Debian's packages (a venv that does not see them: no NumPy, no wheel, no
# pybind11): one paragraph naming what is missing and the command to use.
/usr/bin/python3 -m venv "$scratch/bare"
if "$scratch/bare/bin/pip" install --no-index --no-build-isolation "$source_dir" >"$scratch/bare.log" 2>&1; then
  echo "pip install . with an interpreter lacking NumPy and wheel succeeded: expected the refusal" >&2
  exit 1
fi
for expected in "haustra cannot be built with this Python" "numpy (python3-numpy)" "/usr/bin/python3 -m venv"; do
  if ! tr '\n' ' ' <"$scratch/bare.log" | tr -s ' ' | grep -qF "$expected"; then
    echo "the refusal does not say '$expected':" >&2
    cat "$scratch/bare.log" >&2
    exit 1
  fi
done
if grep -q "Traceback" "$scratch/bare.log"; then
  echo "the refusal is a traceback:" >&2
  cat "$scratch/bare.log" >&2
  exit 1
fi
echo "pip install . without Debian's packages: refused with the paragraph naming them"
