#!/usr/bin/env python3
"""Writing state (decision 0102): a rod bent into an arc by its strains, placed through the points of a
measured curve, moved rigidly by its base, loaded along its length per metre — then stepped from there.

    PYTHONPATH=build/release/python python3 python/examples/write_state.py
"""
import numpy as np

import haustra

ROD = {"world": {"dt": 0.01, "threads": 1, "gravity": [0.0, 0.0, 0.0]},
       "segment": [{"name": "rod", "nodes": 41, "youngs_modulus": 1e6, "rest": {"length": 1.0}}]}


def main():
    world = haustra.World(ROD)
    # 1. The configuration is the base pose and the strains (κ1, κ2, τ, ε per node): a quarter circle.
    strains = np.zeros((world.node_count, 4))
    strains[:, 0] = np.pi / 2  # rad per metre over 1 m
    world.set_strains(strains)
    print("arc: tip at [" + " ".join(f"{v:.15f}" for v in world.node_positions[-1]) + "]")
    # 2. Positions are not free: set_node_positions finds the configuration through the points (frames that
    # turn least, each section an arc), here a measured S-curve with 0.1 mm of noise.
    s = np.linspace(0.0, 1.0, world.node_count)
    curve = np.stack([s, 0.1 * np.sin(2 * np.pi * s), np.zeros_like(s)], axis=1)
    curve += np.random.default_rng(1).normal(0.0, 1e-4, curve.shape)
    world.set_node_positions(curve)
    print(f"placed through the curve: farthest node {np.abs(world.node_positions - curve).max():.1e} m from its "
          f"point; stretch {world.strains[:, 3].min():+.3f} to {world.strains[:, 3].max():+.3f}")
    # 3. Poses read from one world written into another: the same rod (each section's strain to rounding; how
    # a section's strain is split between its two nodes is each world's own).
    other = haustra.World(ROD)
    other.set_node_poses(world.node_positions, world.node_rotations)
    sections = [0.5 * (w.strains[1:] + w.strains[:-1]) for w in (world, other)]
    print(f"poses copied: nodes agree to {np.abs(other.node_positions - world.node_positions).max():.1e} m, "
          f"sections' strains to {np.abs(sections[0] - sections[1]).max():.1e}")
    # 4. A rigid move of the base: a quarter turn about z, 10 cm up.
    other.set_base_pose(0, [0.0, 0.0, 0.1], [np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])
    # 5. A load per metre along the rod (N/m), and loads on many nodes in one call.
    other.set_distributed_load(0, [0.0, 0.0, -0.5])
    other.set_external_loads([-1, -2], [[0.0, 0.1, 0.0], [0.0, 0.1, 0.0]], add=True)
    other.step(100)
    print("after 100 frames under the load: tip at", np.round(other.node_positions[-1], 4))


if __name__ == "__main__":
    main()
