#!/usr/bin/env python3
"""A batch of rollouts: 200 copies of one organ, each under its own random load at its tip, stepped
together on the engine's threads in one call (haustra.Batch, decision 0103), their tips recorded; the
spread of where the tips end up, plotted. Each world's frames are the same bits as stepping it alone.

    PYTHONPATH=build/release/python python3 python/examples/batch_rollouts.py --out out/python
"""
import argparse
import copy
import pathlib
import time

import numpy as np

import haustra

ROOT = pathlib.Path(__file__).resolve().parents[2]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/python")
    parser.add_argument("--worlds", type=int, default=200)
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    rng = np.random.default_rng(7)
    # One world built, the rest copied from it (a copy restores its checkpoint: no second scene read).
    first = haustra.World.from_scene(ROOT / "scenes" / "cantilever.toml", overrides={"world.threads": 1})
    worlds = [first] + [copy.deepcopy(first) for _ in range(args.worlds - 1)]
    # Up to about the scene's own tip load (PL²/B = 3) again, in any direction.
    loads = rng.normal(0.0, 1e-6, size=(args.worlds, 3))
    for w, load in zip(worlds, loads):
        w.add_external_load(-1, load)
    batch = haustra.Batch(worlds, threads=args.threads)
    started = time.perf_counter()
    recordings = batch.step(args.frames, record=["node_positions"])
    seconds = time.perf_counter() - started
    tips = np.stack([r["node_positions"][:, -1] for r in recordings])  # worlds × frames × 3
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    np.save(out / "batch_tips.npy", tips)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5, 4))
    ax.scatter(tips[:, -1, 1], tips[:, -1, 2], s=6, c=loads[:, 2], cmap="coolwarm")
    ax.set_xlabel("tip y (m)")
    ax.set_ylabel("tip z (m)")
    ax.set_title(f"{args.worlds} rollouts, {args.frames} frames")
    fig.tight_layout()
    fig.savefig(out / "batch_rollouts.png", dpi=100)
    print(f"{args.worlds} worlds x {args.frames} frames on {batch.threads} threads: {seconds:.2f} s, "
          f"{args.worlds * args.frames / seconds:,.0f} world-frames/s; tip z from {tips[:, -1, 2].min():.4f} to "
          f"{tips[:, -1, 2].max():.4f} m; wrote {out / 'batch_rollouts.png'}")


if __name__ == "__main__":
    main()
