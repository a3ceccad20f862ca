#!/usr/bin/env python3
"""Checkpoints: the demo grasped and lifted, saved once, then three futures branched from the same
instant (released, held, pulled aside) and one replayed to show it continues bit for bit; a copy of a
world (pickle, copy.deepcopy) is a checkpoint too.

    PYTHONPATH=build/release/python python3 python/examples/checkpoints.py
"""
import copy
import pathlib
import pickle

import numpy as np

import haustra

ROOT = pathlib.Path(__file__).resolve().parents[2]


def main():
    world = haustra.World.from_scene(ROOT / "scenes" / "grasp-pull.toml", overrides={"world.threads": 1})
    world.step(40)
    saved = world.save_checkpoint()  # bytes: everything a later frame depends on
    print(f"checkpoint at frame {world.frame}: {len(saved)} bytes")
    tips = {}
    for branch in ("released", "held", "aside"):
        world.restore_checkpoint(saved)
        tip = np.array(world.instrument(0)["tip"])
        if branch == "released":
            world.release(0)
        elif branch == "aside":
            world.set_instrument_pose(0, tip + [0.0, 0.05, 0.0], [0.0, 0.0, 1.0])
        else:
            world.set_instrument_pose(0, tip, [0.0, 0.0, 1.0])
        world.step(30)
        tips[branch] = np.array(world.node_positions[-1])
        print(f"{branch:>8}: organ's tip at {np.round(tips[branch], 4)}")
    # The same branch again from the same bytes: the same bits.
    world.restore_checkpoint(saved)
    world.release(0)
    world.step(30)
    assert np.array_equal(world.node_positions[-1], tips["released"])
    # A copy (through pickle, as a Dask worker gets it) continues as the original does.
    twin = pickle.loads(pickle.dumps(world))
    deep = copy.deepcopy(world)
    for w in (world, twin, deep):
        w.step(10)
    assert np.array_equal(twin.node_positions, world.node_positions)
    assert np.array_equal(deep.node_positions, world.node_positions)
    print("replayed and copied: the same bits")


if __name__ == "__main__":
    main()
