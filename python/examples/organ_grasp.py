#!/usr/bin/env python3
"""An imported organ grasped and pulled: a segmented surface made into a scene by the `haustra` command
(`haustra import`, CGAL's repair, off the module), then the organ protocol's grasper (decision 0097) —
left alone, grasped above its middle, pulled 5 cm sideways, held, released — run from Python, with the
grasp's force and the grasped node's travel plotted.

    PYTHONPATH=build/release/python python3 python/examples/organ_grasp.py --out out/python
    .venv/bin/python python/examples/organ_grasp.py SURFACE.obj --out out/python   # an installed package
"""
import argparse
import pathlib
import shutil
import subprocess

import numpy as np

import haustra
from haustra.studies.cells import haustra_command

ROOT = pathlib.Path(__file__).resolve().parents[2]
SURFACE = ROOT / "tests" / "data" / "anatomy" / "HuBMAPVHM-00070-large-intestine-Rectum.obj"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("surface", nargs="?", default=str(SURFACE), help="a segmented surface (.obj, .stl, .off, .glb)")
    parser.add_argument("--out", default="out/python", help="folder for the import, organ_grasp.csv and .png")
    parser.add_argument("--rest", type=float, default=2.0, help="seconds left alone before the grasp (10 in make anatomy)")
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    imported = out / "organ"
    shutil.rmtree(imported, ignore_errors=True)
    imported.mkdir(parents=True)
    # `haustra anatomy` on a folder of the one surface: the import and the protocol's grasper, as make anatomy
    # does it; protocol.toml is the imported scene with that grasper on its keyframes.
    folder = imported / "surface"
    folder.mkdir()
    surface = pathlib.Path(args.surface).resolve()
    for part in [surface, surface.with_name(surface.stem + "-centreline.json")]:  # its centreline, if given
        if part.exists():
            (folder / part.name).symlink_to(part)
    subprocess.run([haustra_command(), "anatomy", str(folder), "--out", str(imported), "--threads", "1"],
                   check=True, capture_output=True, text=True)
    scene = imported / pathlib.Path(args.surface).stem / "protocol.toml"
    # The protocol's keyframes start after 10 s left alone; shift time by starting the clock later.
    world = haustra.World.from_scene(scene, overrides={"world.threads": 1})
    skip = round((10.0 - args.rest) / world.dt)
    world.step(skip)  # left alone (the keyframes are in absolute time)
    start = np.array(world.node_positions)
    frames = round((args.rest + 0.5 + 1.0 + 1.0 + 3.0) / world.dt)
    recording = world.step(frames, record=["node_positions", "instrument_force", "instrument_tip"])
    t = recording["time"]
    force = np.linalg.norm(recording["instrument_force"][:, 0], axis=1)
    grasped = world.instrument(0)
    drift = np.linalg.norm(recording["node_positions"] - start, axis=2)  # frames × nodes, m
    moved = drift.max(axis=1)
    np.savetxt(out / "organ_grasp.csv", np.column_stack([t, force, moved]), delimiter=",",
               header="time_s,force_N,farthest_node_moved_m", comments="")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    a.plot(t, force)
    a.set_ylabel("force on the grasper (N)")
    b.plot(t, 1e3 * moved)
    b.set_ylabel("farthest node from rest (mm)")
    b.set_xlabel("time (s)")
    a.set_title(f"{pathlib.Path(args.surface).stem}: grasped, pulled 5 cm, held, released")
    fig.tight_layout()
    fig.savefig(out / "organ_grasp.png", dpi=100)
    print(f"{world.node_count} nodes; largest force {force.max():.2f} N; farthest node {1e3 * moved.max():.1f} mm "
          f"from rest; after release {1e3 * moved[-1]:.2f} mm; slipped {grasped['slipped']}; "
          f"wrote {out / 'organ_grasp.png'}")


if __name__ == "__main__":
    main()
