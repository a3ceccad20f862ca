"""A typed study in a dozen lines: a cantilever's tip sag against Euler–Bernoulli, recorded in one call.

Checked with `mypy --strict` in make test (the package ships its stubs and py.typed).
    PYTHONPATH=build/release/python python3 python/examples/typed_study.py [scenes/cantilever.toml]
"""
import sys

import numpy as np

import haustra
from haustra.types import Profile


def tip_sag(scene: str, nodes: int) -> float:
    world = haustra.World.from_scene(scene, overrides={"segment.nodes": nodes, "world.threads": 1})
    recording = world.step(world.scene_frames, record=["node_positions", "profile"])  # a dict: record= given
    last: Profile = world.profile
    print(f"{nodes:4d} nodes: {last['frame_seconds'] * 1e6:7.1f} µs/frame, "
          f"{int(recording['profile']['iterations'].sum())} iterations")
    return float(-recording["node_positions"][-1, -1, 2])


if __name__ == "__main__":
    scene = sys.argv[1] if len(sys.argv) > 1 else "scenes/cantilever.toml"
    sags = np.array([tip_sag(scene, n) for n in (11, 21, 41)])
    print("tip sag, m:", sags, "— change from the finest:", np.abs(sags - sags[-1]))
