"""Writing state from arrays (decision 0102): strains, node poses and positions, a base pose; many
nodes' loads in one call; loads per metre along the rod, in scenes and at run time."""
import copy

import numpy as np
import pytest

import haustra
from conftest import rod


def still_rod(nodes=21, gravity=(0.0, 0.0, 0.0), **world):
    """The test rod (without gravity unless given) without the inertia filter: its nodes are exactly where its
    strains put them."""
    desc = rod(nodes=nodes, gravity=list(gravity), **world)
    desc["filter"] = {"enabled": False}
    return desc


def bits(w):
    return [np.array(w.node_positions).tobytes(), np.array(w.node_rotations).tobytes(), np.array(w.strains).tobytes()]


def test_strains_written_rebuild_the_rod_as_an_arc():
    w = haustra.World(still_rod())
    strains = np.zeros((w.node_count, 4))
    strains[:, 0] = 2.0  # κ1 = 2 /m: a 1 m rod turns by 2 rad on a circle of radius 0.5 m
    w.set_strains(strains)
    assert np.array_equal(w.strains, strains)
    p = w.node_positions
    # The base at the origin along x, bending about d1: the nodes lie on a circle of radius 0.5 m through the
    # origin, tangent to x there; its centre is 0.5 m off the axis, in the plane the bend turns in.
    normal = p[-1] - p[0] - np.dot(p[-1] - p[0], [1, 0, 0]) * np.array([1.0, 0.0, 0.0])
    centre = 0.5 * normal / np.linalg.norm(normal)
    assert np.abs(np.linalg.norm(p - centre, axis=1) - 0.5).max() < 2e-15  # measured 2.2e-16 (rounding)
    assert np.allclose(w.node_velocities, 0.0) and np.allclose(w.angular_velocities, 0.0)


def test_strains_refused_whole_naming_what_is_wrong():
    w = haustra.World(still_rod())
    before = bits(w)
    bad = np.zeros((w.node_count, 4))
    bad[7, 2] = np.nan
    with pytest.raises(haustra.InvalidArgumentError, match=r"set_strains: node 7's strain 2 is nan"):
        w.set_strains(bad)
    with pytest.raises(haustra.InvalidArgumentError, match=r"strains has shape \(3, 4\); expected \(21, 4\)"):
        w.set_strains(np.zeros((3, 4)))
    bad = np.zeros((w.node_count, 4))
    bad[3, 3] = -1.0
    with pytest.raises(haustra.InvalidArgumentError, match=r"node 3's axial strain"):
        w.set_strains(bad)
    assert bits(w) == before  # nothing written


def test_strains_written_step_on_as_a_restored_checkpoint(scenes):
    # A world stepped under its load, its strains read; a fresh world given those strains steps on with the
    # same bits as one restored from the first world's checkpoint: the strains (and the base) are the
    # configuration, and with the filter off the nodes are where they put them.
    desc = still_rod(nodes=21)
    desc["world"]["gravity"] = [0.0, 0.0, -9.81]
    a = haustra.World(desc)
    a.step(25)
    strains, checkpoint = np.array(a.strains), a.save_checkpoint()
    written, restored = haustra.World(desc), haustra.World(desc)
    written.set_strains(strains)
    restored.restore_checkpoint(checkpoint)
    assert np.array_equal(written.node_positions, restored.node_positions)
    written.step(30)
    restored.step(30)
    assert bits(written) == bits(restored)


def test_node_poses_read_and_written_back_give_the_rod_again():
    w = haustra.World(still_rod(gravity=[0.0, 0.0, -9.81]))
    w.step(20)
    positions, rotations, strains = np.array(w.node_positions), np.array(w.node_rotations), np.array(w.strains)
    sections = 0.5 * (strains[1:] + strains[:-1])  # what the configuration holds: each section's strain
    fresh = haustra.World(still_rod())
    fresh.set_node_poses(positions, rotations)
    assert np.abs(fresh.node_positions - positions).max() < 3e-15  # measured 2.8e-16
    assert np.abs(np.abs(np.sum(fresh.node_rotations * rotations, axis=1)) - 1).max() < 2e-15  # measured 2.2e-16
    assert np.abs(0.5 * (fresh.strains[1:] + fresh.strains[:-1]) - sections).max() < 4e-14  # measured 4.0e-15
    # The split of the sections' strains between their nodes is the world's own (the least change from what its
    # nodes held): written back into the world they came from, the poses give its node strains again.
    w.set_node_poses(positions, rotations)
    assert np.abs(w.strains - strains).max() < 2e-13  # measured 1.5e-14


def test_node_poses_that_shear_the_rod_are_refused():
    w = haustra.World(still_rod())
    before = bits(w)
    positions, rotations = np.array(w.node_positions), np.array(w.node_rotations)
    positions[9, 2] += 1e-3  # 1 mm sideways: sections 8 and 9 would shear
    with pytest.raises(haustra.InvalidArgumentError, match=r"section 8 \(nodes 8 and 9\): the poses shear it by 0\.001 m"):
        w.set_node_poses(positions, rotations)
    rotations[4] *= 2.0
    with pytest.raises(haustra.InvalidArgumentError, match=r"node 4's rotation has norm 2"):
        w.set_node_poses(positions, rotations)
    assert bits(w) == before


def test_positions_written_place_the_rod_through_them():
    w = haustra.World(still_rod(nodes=41))
    # Points on a helix of radius 0.2 m and pitch 0.5 m per turn, 1.2 m of it over 40 sections of 3 cm (the
    # rod's rest sections are 2.5 cm: the sections stretch by 20 %).
    radius, pitch = 0.2, 0.5 / (2 * np.pi)
    speed = np.hypot(radius, pitch)
    t = np.linspace(0.0, 1.2, w.node_count) / speed
    target = np.stack([radius * np.cos(t), radius * np.sin(t), pitch * t], axis=1)
    w.set_node_positions(target)
    assert np.abs(w.node_positions - target).max() < 2e-15  # measured 1.7e-16
    # The stretch: 1.2 m of helix on 1 m of rod, each section an arc through its two points (measured within
    # 6.9e-6 of 0.2; the first frame's tangent chosen so that the sections' bends do not zig-zag).
    assert np.abs(w.strains[:, 3] - 0.2).max() < 7e-5
    # No twist is made (frames that turn least); the bend is the helix's curvature, to the discretization.
    curvature = radius / speed**2
    bend = np.linalg.norm(w.strains[1:-1, :2], axis=1) / (1 + w.strains[1:-1, 3])  # per metre of the helix
    assert np.abs(bend - curvature).max() < 0.05 * curvature  # measured 1.1 % (5x: how the frames turn varies)


def test_positions_that_cannot_be_a_rod_are_refused():
    w = haustra.World(still_rod())
    before = bits(w)
    target = np.array(w.node_positions)
    target[5] = target[4]
    with pytest.raises(haustra.InvalidArgumentError, match=r"nodes 4 and 5 are at the same place"):
        w.set_node_positions(target)
    zigzag = np.array(w.node_positions)
    zigzag[1::2, 1] += 0.05  # 5 cm sideways every other node of 5 cm sections: 90 degrees and more per section
    with pytest.raises(haustra.InvalidArgumentError, match=r"more than 90° within one section"):
        w.set_node_positions(zigzag)
    with pytest.raises(haustra.InvalidArgumentError, match=r"positions has shape \(21,\); expected \(21, 3\)"):
        w.set_node_positions(np.zeros(21))
    assert bits(w) == before


def test_a_base_pose_moves_the_rod_rigidly():
    w = haustra.World(still_rod())
    strains = np.zeros((w.node_count, 4))
    strains[:, 1] = 1.0
    w.set_strains(strains)
    before, frame = np.array(w.node_positions), np.array(w.directors[0])
    quarter = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])  # the base's new frame: a quarter turn about z
    w.set_base_pose(0, [1.0, 2.0, 3.0], quarter)
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]) @ frame.T  # from the old frame to the new
    moved = (before - before[0]) @ turn.T + [1.0, 2.0, 3.0]
    assert np.abs(w.node_positions - moved).max() < 1.5e-14  # measured 1.3e-15
    assert np.array_equal(w.strains, strains)
    with pytest.raises(haustra.InvalidArgumentError, match=r"expected a unit quaternion"):
        w.set_base_pose(0, [0, 0, 0], [1, 1, 0, 0])
    with pytest.raises(haustra.InvalidArgumentError, match=r"rotation must be 4 numbers"):
        w.set_base_pose(0, [0, 0, 0], [1, 0, 0])


def test_many_loads_in_one_call_equal_one_call_per_node():
    one, many = haustra.World(rod()), haustra.World(rod())
    nodes = [3, -1, 10, 3]
    forces = np.array([[0.0, 0.1, 0.0], [0.0, 0.0, -0.2], [0.05, 0.0, 0.0], [0.0, 0.1, 0.0]])
    moments = np.array([[0.0, 0.0, 0.01], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    many.set_external_loads(nodes, forces, moments)
    one.set_external_load(3, forces[0] + forces[3], moments[0] + moments[3])  # a node listed twice: the sum
    one.set_external_load(-1, forces[1], moments[1])
    one.set_external_load(10, forces[2], moments[2])
    for node in range(one.node_count):
        assert all(np.array_equal(a, b) for a, b in zip(one.external_load(node), many.external_load(node)))
    one.step(10)
    many.step(10)
    assert bits(one) == bits(many)
    many.set_external_loads([10], [[0.05, 0.0, 0.0]], add=True)
    assert np.array_equal(many.external_load(10)[0], [0.1, 0.0, 0.0])
    with pytest.raises(haustra.InvalidIndexError, match=r"nodes\[1\] = 21 is out of range \(the world has 21 nodes"):
        many.set_external_loads([0, 21], np.zeros((2, 3)))
    with pytest.raises(haustra.InvalidArgumentError, match=r"forces has shape \(3, 3\); expected \(2, 3\)"):
        many.set_external_loads([0, 1], np.zeros((3, 3)))
    with pytest.raises(haustra.InvalidArgumentError, match=r"the load on node 1 \(entry 1\) is not finite"):
        many.set_external_loads([0, 1], [[0, 0, 0], [0, np.inf, 0]])
    assert np.array_equal(many.external_load(0)[0], [0.0, 0.0, 0.0])  # refused whole


def test_a_load_per_metre_is_lumped_and_bends_a_cantilever_as_beam_theory_says():
    # A uniform load q on a clamped 1 m rod: the nodes share q·L (each half of the sections beside it), and a
    # small load bends it as Euler–Bernoulli's cantilever, tip deflection q L⁴ / (8 B).
    desc = still_rod(nodes=41, youngs_modulus=1e7)
    desc["segment"][0]["law"] = {"bending": "elastic", "torsion": "elastic"}  # the paper's bending is viscous: it creeps
    w = haustra.World(desc)
    q = 0.02  # N/m, along -z
    w.set_distributed_load(0, [0.0, 0.0, -q])
    loads = np.array([w.external_load(k)[0] for k in range(w.node_count)])
    assert abs(loads[:, 2].sum() + q * 1.0) < 1e-15
    assert loads[0, 2] == pytest.approx(-q * 0.0125, rel=1e-12) and loads[5, 2] == pytest.approx(-q * 0.025, rel=1e-12)
    w.step(200)
    bending = w.segments[0]["bending_stiffness"]
    expected = q / (8 * bending)
    assert abs(-w.node_positions[-1, 2] - expected) < 2e-3 * expected  # measured 2.1e-4 of it


def test_a_load_per_metre_in_a_scene_is_the_same_as_set_at_run_time():
    desc = still_rod(nodes=21)
    written = haustra.World(desc)
    written.set_distributed_load(0, [0.0, 0.3, -0.1])
    scene = copy.deepcopy(desc)
    scene["segment"][0]["distributed_load"] = [{"force": [0.0, 0.3, -0.1]}]  # the whole segment
    scened = haustra.World(scene)
    for k in range(21):
        assert np.array_equal(written.external_load(k)[0], scened.external_load(k)[0])
    written.step(10)
    scened.step(10)
    assert bits(written) == bits(scened)
    # A range: its end nodes take half a section each; rows given per node take each node's whole share.
    scene["segment"][0]["distributed_load"] = [{"from": 5, "to": -6, "force": [0.0, 0.3, 0.0]}]
    ranged = haustra.World(scene)
    per_node = np.zeros((21, 3))
    per_node[5:16, 1] = 0.3
    written.set_distributed_load(0, per_node)
    totals = [sum(w.external_load(k)[0][1] for k in range(21)) for w in (ranged, written)]
    assert totals[0] == pytest.approx(0.3 * 0.5, rel=1e-12)  # nodes 5 to 15: 10 sections of 5 cm
    assert totals[1] == pytest.approx(0.3 * 0.55, rel=1e-12)  # 11 nodes' shares of 5 cm
    bad = copy.deepcopy(desc)
    bad["segment"][0]["distributed_load"] = [{"from": 5, "to": 3, "force": [0.0, 0.3, 0.0]}]
    with pytest.raises(haustra.InvalidArgumentError, match=r"distributed_load\[0\]\.to: node 3 comes before"):
        haustra.World(bad)
    with pytest.raises(haustra.InvalidArgumentError, match=r"force has shape \(2, 3\); expected \(21, 3\)"):
        written.set_distributed_load(0, np.zeros((2, 3)))
