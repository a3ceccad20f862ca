"""Shared fixtures: where the sources, scenes and the `haustra` command are (set by ctest)."""
import os
import pathlib

import pytest

SOURCE = pathlib.Path(os.environ.get("HAUSTRA_SOURCE", pathlib.Path(__file__).resolve().parents[2]))
SCENES = SOURCE / "scenes"
BIN = os.environ.get("HAUSTRA_BIN", str(SOURCE / "build" / "release" / "bin" / "haustra"))


def rod(nodes=21, youngs_modulus=1e6, **world):
    """A 1 m rod clamped at the origin, horizontal, under gravity: the scene format as a dict.
    Stiffer than the paper's rectum (33.2 kPa), which cannot hold itself out straight
    (docs/stability.md)."""
    return {
        "world": {"dt": 0.01, "threads": 1, **world},
        "segment": [{"name": "rod", "nodes": nodes, "youngs_modulus": youngs_modulus, "rest": {"length": 1.0}}],
    }


@pytest.fixture
def scenes():
    return SCENES


@pytest.fixture
def haustra_bin():
    return BIN
