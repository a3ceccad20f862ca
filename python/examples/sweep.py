#!/usr/bin/env python3
"""A parameter sweep: node count x Newton iterations -> tip error and cost per frame, plotted.

The case is scenes/cantilever.toml with its load raised to PL^2/B = 10 (a large deflection) and
applied at once: its tip after two frames, against the same run with twice the most nodes and
iterations of the sweep (the reference). Few iterations have not reached the elastica yet; few
nodes reach a coarser one. Cost is the mean frame time from the engine's own profile.

    PYTHONPATH=build/release/python python3 python/examples/sweep.py --out out/python
"""
import argparse
import pathlib
import tomllib

import numpy as np

import haustra

ROOT = pathlib.Path(__file__).resolve().parents[2]


def tip_and_cost(desc, nodes, iterations, frames):
    """The tip after `frames` frames and the mean frame time, recorded in one call (no Python loop)."""
    w = haustra.World(desc, overrides={"segment.nodes": nodes, "solver.iterations": iterations})
    recording = w.step(frames, record=["node_positions", "profile"])
    return recording["node_positions"][-1, -1], recording["profile"]["frame_seconds"].mean()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/python", help="folder for sweep.csv and sweep.png")
    parser.add_argument("--quick", action="store_true", help="a small sweep (for the tests)")
    args = parser.parse_args()
    with open(ROOT / "scenes" / "cantilever.toml", "rb") as f:
        scene = tomllib.load(f)  # the scene as a dict: World(desc) takes the same keys
    load = scene["segment"][0]["load"][0]
    load["force"] = [0.0, 0.0, load["force"][2] * 10.0 / 3.0]  # PL²/B = 3 -> 10
    nodes = [11, 21, 41] if args.quick else [11, 21, 41, 81, 161]
    iterations = [1, 2, 4] if args.quick else [1, 2, 4, 8]
    frames = 2
    tip_and_cost(scene, nodes[0], iterations[0], frames)  # warm up: the first world pays for page faults
    reference, _ = tip_and_cost(scene, 2 * nodes[-1] - 1, 2 * iterations[-1], frames)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for n in nodes:
        for it in iterations:
            tip, cost = tip_and_cost(scene, n, it, frames)
            rows.append((n, it, float(np.linalg.norm(tip - reference)), cost))
            print(f"nodes {n:4d}  iterations {it}  tip error {rows[-1][2] * 1e3:9.4f} mm  {cost * 1e6:8.1f} us/frame")
    with open(out / "sweep.csv", "w") as f:
        f.write("nodes,iterations,tip_error_m,frame_seconds\n")
        for r in rows:
            f.write(f"{r[0]},{r[1]},{r[2]:.9g},{r[3]:.9g}\n")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    for it in iterations:
        sel = [r for r in rows if r[1] == it]
        ax.loglog([r[3] * 1e6 for r in sel], [max(r[2], 1e-12) * 1e3 for r in sel], "o-", label=f"{it} iterations")
        for r in sel:
            ax.annotate(str(r[0]), (r[3] * 1e6, max(r[2], 1e-12) * 1e3), fontsize=7)
    ax.set_xlabel("cost per frame (us)")
    ax.set_ylabel("tip error against the finest run (mm)")
    ax.set_title("cantilever, PL²/B = 10: nodes (labels) x Newton iterations")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "sweep.png", dpi=100)
    print(f"wrote {out / 'sweep.csv'} and {out / 'sweep.png'}")


if __name__ == "__main__":
    main()
