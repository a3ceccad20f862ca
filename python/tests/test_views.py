"""Views: the engine's buffers without copies, live across steps, valid after the world is gone."""
import gc

import numpy as np
import pytest

import haustra
from conftest import rod


def address(a):
    return a.__array_interface__["data"][0]


def test_views_share_the_engines_memory(scenes):
    w = haustra.World.from_scene(str(scenes / "demo.toml"))
    n, v = w.node_count, w.mesh_positions.shape[0]
    p = w.node_positions
    assert p.shape == (n, 3) and p.dtype == np.float64
    assert p.strides == (8, 8 * n)  # x[], y[], z[] of one block: no copy can have this layout
    assert address(w.node_positions) == address(p)  # a second view: the same memory
    assert not p.flags.writeable and not p.flags.owndata
    with pytest.raises(ValueError):
        p[0, 0] = 1.0
    m = w.mesh_positions
    assert m.dtype == np.float32 and m.strides == (4, 4 * v)
    assert w.strains.shape == (n, 4) and w.strains.strides == (32, 8)
    assert address(w.strains) == address(w.strains)
    t = w.mesh_triangles
    assert t.dtype == np.uint32 and t.shape[1] == 3 and int(t.max()) < v
    assert np.shares_memory(w.mesh_normals, w.mesh_normals)


def test_a_view_shows_the_last_completed_step(scenes):
    w = haustra.World.from_scene(str(scenes / "drop.toml"))
    p = w.node_positions
    before = np.array(p)
    w.step(10)
    assert not np.array_equal(p, before)  # the same view, now at frame 10
    assert np.array_equal(p, w.node_positions)
    # Bead centres are their nodes' positions after the step.
    assert np.array_equal(w.bead_centres, w.node_positions[w.bead_nodes])


def test_mesh_views_after_a_step(scenes):
    w = haustra.World.from_scene(str(scenes / "demo.toml"))
    w.step(5)
    lengths = np.linalg.norm(w.mesh_normals.astype(np.float64), axis=1)
    assert np.abs(lengths - 1.0).max() < 1e-6  # float32 normals (measured 1.5e-7)
    assert np.isfinite(w.mesh_positions).all()


def test_a_view_outlives_its_world():
    w = haustra.World(rod())
    w.step(3)
    p, q = w.node_positions, w.strains
    kept_p, kept_q = np.array(p), np.array(q)
    del w
    gc.collect()
    # Still the engine's memory (kept by the view's base), still what it held.
    assert np.array_equal(p, kept_p) and np.array_equal(q, kept_q)
    assert p.base is not None


def test_a_view_outlives_a_removed_segment(scenes):
    w = haustra.World.from_scene(str(scenes / "two-segments.toml"))
    w.step(2)
    old = w.node_positions
    kept = np.array(old)
    w.remove_segment(1)
    gc.collect()
    assert np.array_equal(old, kept)  # the old buffers, frozen at their last step
    w.step(5)
    assert np.array_equal(old, kept)  # no longer updated: the world moved to new buffers
    assert w.node_positions.shape[0] == w.node_count < old.shape[0]


def test_a_held_mesh_view_stays_live_though_the_mesh_is_made_when_read(scenes):
    # The engine makes the mesh only when it is read (decision 0060); a view taken once must still
    # show the last step's mesh, as every other view does.
    w = haustra.World.from_scene(scenes / "demo.toml", overrides={"segment.mesh.procedural.vertices": 2000})
    held, normals = w.mesh_positions, w.mesh_normals
    before = np.array(held)
    w.step(5)
    assert not np.array_equal(held, before)
    reference = haustra.World.from_scene(scenes / "demo.toml", overrides={"segment.mesh.procedural.vertices": 2000})
    reference.step(5)
    assert np.array_equal(held, reference.mesh_positions) and np.array_equal(normals, reference.mesh_normals)
