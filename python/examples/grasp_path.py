#!/usr/bin/env python3
"""Drives the demo's grasper along a path (down, grasp, lift, pull aside) and plots its force.

The force is what the tissue exerts on the instrument: what a haptic device would render. Raw and
low-passed (the instrument's force_filter) are both plotted.

    PYTHONPATH=build/release/python python3 python/examples/grasp_path.py --out out/python
"""
import argparse
import pathlib

import numpy as np

import haustra

ROOT = pathlib.Path(__file__).resolve().parents[2]


def path(t, above):
    """Tip position at time t (s): down onto the organ, grasp at 0.5 s, lift, then pull aside."""
    lift = np.array([0.0, 0.0, 0.25])
    aside = np.array([-0.15, 0.25, 0.0])
    if t < 0.5:
        return above + [0.0, 0.0, 0.10 * (1 - t / 0.5)]
    if t < 1.5:
        return above + lift * (t - 0.5)
    return above + lift + aside * min(1.0, (t - 1.5) / 1.5)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/python", help="folder for grasp_force.csv and grasp_force.png")
    parser.add_argument("--seconds", type=float, default=3.0)
    args = parser.parse_args()
    w = haustra.World.from_scene(str(ROOT / "scenes" / "demo.toml"))
    node = w.node_count // 2
    w.step()
    above = np.array(w.node_positions[node]) + [0.0, 0.0, 0.025]  # the jaws' reach above the middle node
    axis = [0.0, 0.0, 1.0]
    rows = []
    for f in range(int(round(args.seconds / w.dt))):
        t = f * w.dt
        w.set_instrument_pose(0, path(t, above), axis)
        if f == int(0.5 / w.dt):
            w.grasp(0)
        w.step()
        r = w.instrument(0)
        rows.append((w.time, *r["force"], *r["filtered_force"], r["grasping"]))
    w.release(0)
    w.step()
    data = np.array(rows, dtype=float)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    np.savetxt(out / "grasp_force.csv", data, delimiter=",", comments="",
               header="time_s,fx_N,fy_N,fz_N,filtered_fx_N,filtered_fy_N,filtered_fz_N,grasping")
    held = data[:, 7] > 0
    peak = np.linalg.norm(data[held, 1:4], axis=1).max() if held.any() else 0.0
    print(f"grasped for {held.sum()} of {len(data)} frames; peak force {peak:.3f} N")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 3.5))
    for i, name in enumerate("xyz"):
        line, = ax.plot(data[:, 0], data[:, 1 + i], lw=0.8, alpha=0.5, label=f"F{name} raw")
        ax.plot(data[:, 0], data[:, 4 + i], lw=1.6, color=line.get_color(), label=f"F{name} filtered")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("force on the grasper (N)")
    ax.legend(ncol=3, fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "grasp_force.png", dpi=100)
    print(f"wrote {out / 'grasp_force.csv'} and {out / 'grasp_force.png'}")


if __name__ == "__main__":
    main()
