#!/usr/bin/env bash
# Regenerates every picture of docs/figures/ from scratch (`make figures`): the paper's Figs. 2, 4,
# 6 and 7, the CT colon grasped and pulled, and the demo's plots. Captions: docs/figures/README.md.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/release/bin/haustra
out=docs/figures
runs=build/figures
mkdir -p "$out" "$runs"

# Fig. 7: the drop, frames 0, 60 and 270, with a procedural mesh on its 55 beads.
$bin render scenes/drop.toml --frames 0 60 270 --set segment.mesh.source=procedural --out "$out/fig7-drop.png"
# Fig. 6: beads, cage, and one sharp bend skinned by linear blending and by the cage.
$bin figure-cage --out "$out/fig6-cage.png"
# The CT colon at rest, while pulled, and its cage.
$bin render scenes/anatomy-grasp.toml --frames 0 120 239 --view 0 -1 0.35 --out "$out/ct-colon-grasp.png"
$bin render scenes/anatomy-grasp.toml --frames 0 --overlay cage --view 0 -1 0.35 --out "$out/ct-colon-cage.png"
# The demo coloured by bending strain, and its beads by penetration.
$bin render scenes/demo.toml --frames 120 --colour strain --out "$out/demo-strain.png"
$bin render scenes/bowel.toml --frames 0 150 299 --width 560 --height 440 --columns 3 --view 0.4 -1 0.9 \
  --out "$out/bowel.png"
# Fig. 4: elastic (light, small deflection) and viscous rods held at both ends, after 50 s.
$bin run scenes/sag.toml --quiet --frames 3000 --mesh-every 0 --set "segment[0].linear_density=0.0005" --out "$runs/sag" >/dev/null
/usr/bin/python3 scripts/plots.py fig4 "$runs/sag" "$out/fig4-sag.png"
# Fig. 2: EXP2 against Hooke.
/usr/bin/python3 scripts/plots.py fig2 "$out/fig2-exp2-hooke.png"
# Plots of a run: penetration, instrument force, per-stage time against frame.
$bin run scenes/demo.toml --quiet --mesh-every 0 --out "$runs/demo" >/dev/null
/usr/bin/python3 scripts/plots.py run "$runs/demo" "$out/demo"
# The viewer, as a person sees it: the demo grasped, the help, File > Open, the inspector on a real
# large intestine, the small intestine's loops grasped.
./scripts/viewer-shots.sh
echo "figures written to $(pwd)/$out"
