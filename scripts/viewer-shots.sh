#!/usr/bin/env bash
# Regenerates the viewer's pictures in docs/figures/ (`make viewer-shots`, also run by `make
# figures`): each script of scripts/viewer/ played in `haustra view` under Xvfb with Mesa's
# software OpenGL, as the guide's viewer section shows them.
set -euo pipefail
cd "$(dirname "$0")/.."
view=build/release/bin/haustra-view
shot() {  # SCENE SCRIPT
  xvfb-run -a -s "-screen 0 1280x720x24" "$view" "$1" --script "scripts/viewer/$2.txt" 2>/dev/null
}
shot scenes/demo.toml demo-grasp
shot scenes/demo.toml help
shot scenes/demo.toml open
shot tests/data/anatomy/HuBMAPVHM-00070-large-intestine.obj inspector
shot scenes/small-intestine.toml small-intestine
echo "viewer pictures written to $(pwd)/docs/figures/viewer*.png"
