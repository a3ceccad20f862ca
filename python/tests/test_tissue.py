"""Connective tissue from Python (decision 0095): anchors held where the anatomy holds the organ,
their tensions against the weight they carry, cutting them in a sphere, checkpoints that keep it."""
import pickle

import numpy as np
import pytest

import haustra
from conftest import rod


def held_rod(**anchors):
    """rod(), its base free and the whole of it on connective tissue (a tether of 5 kN/m²)."""
    desc = rod(nodes=41)
    segment = desc["segment"][0]
    segment["base"] = "free"
    segment["drag"] = 1.0
    segment["anchors"] = [{"name": "mesentery", "stiffness": 5000.0, "strength": 0.0, **anchors}]
    return desc


def test_anchors_carry_the_weight_they_hold():
    w = haustra.World(held_rod())
    assert w.anchor_nodes.shape == (41,) and w.anchor_nodes.dtype == np.uint32
    np.testing.assert_array_equal(w.anchor_targets, w.node_positions)  # their rest places
    w.step(200)
    # A uniform load on a uniform foundation: each anchor carries its node's weight, to rounding.
    weight = -w.gravity[2] * w.segments[0]["linear_density"] * w.section_lengths.sum() / 40
    tension = w.anchor_tensions()
    shares = np.full(41, weight)
    shares[[0, -1]] /= 2
    np.testing.assert_allclose(tension, shares, rtol=2e-8)  # measured 2e-9 (the ends still settling)
    assert w.energy["tissue"] > 0
    assert w.anchors_intact.all()


def test_a_cut_frees_the_tissue_in_a_sphere_and_is_kept_by_pickling_and_checkpoints():
    w = haustra.World(held_rod())
    w.step(10)
    middle = w.node_positions[20]
    cut = w.cut_tissue(middle, 0.09)  # within 11 cm of the middle node: 9 cm, and the wall 2 cm round it
    assert cut == 9  # nodes 2.5 cm apart: 16 .. 24
    assert list(np.flatnonzero(~w.anchors_intact)) == list(range(16, 25))
    event = w.events[-1]
    assert event["kind"] == "cut" and "9 anchors of 'mesentery'" in event["message"]
    copy = pickle.loads(pickle.dumps(w))
    np.testing.assert_array_equal(copy.anchors_intact, w.anchors_intact)
    w.step(30)
    copy.step(30)
    np.testing.assert_array_equal(copy.node_positions, w.node_positions)
    # Freed in the middle, it sinks there; held elsewhere.
    assert w.node_positions[20, 2] < w.node_positions[5, 2] - 1e-3
    assert w.anchor_tensions()[20] == 0.0


def test_bad_tissue_is_refused_naming_the_field():
    with pytest.raises(haustra.Error, match=r"segment\[0\]\.anchors\[0\]\.stiffness"):
        haustra.World(held_rod(stiffness=-1.0))
    with pytest.raises(haustra.Error, match=r"segment\[0\]\.anchors\[0\]\.root"):
        haustra.World(held_rod(target="root"))
    w = haustra.World(held_rod())
    with pytest.raises(haustra.InvalidArgumentError, match="radius"):
        w.cut_tissue([0.5, 0.0, 0.0], -1.0)
