"""The rod's whole state (material frames, velocities, section stresses, contact records),
recordings of n frames in one call, and run-time parameters that need no rebuild."""
import numpy as np
import pytest

import haustra
from conftest import rod


def quaternion_matrix(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def test_node_rotations_are_a_live_view_and_directors_their_matrices(scenes):
    w = haustra.World.from_scene(scenes / "cantilever.toml")
    q = w.node_rotations
    before = np.array(q)
    w.step(5)
    assert not np.array_equal(q, before)  # live: the same array shows frame 5
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    d = w.directors
    assert np.allclose(d[7], quaternion_matrix(q[7]), atol=1e-14)
    # d3 is the tangent: along the chord between neighbouring nodes to the rod's curvature.
    chord = np.diff(w.node_positions, axis=0)
    chord /= np.linalg.norm(chord, axis=1)[:, None]
    assert np.abs(np.einsum("ij,ij->i", d[:-1, :, 2], chord) - 1).max() < 1e-3


def test_section_moments_balance_the_tip_load(scenes):
    # The elastica: with a vertical tip load P, the moment at arc length s is P (x_tip − x(s)),
    # exactly, whatever the deflection (statics of the part beyond s).
    w = haustra.World.from_scene(scenes / "cantilever.toml")
    w.step(w.scene_frames)
    force, _ = w.external_load(-1)
    p = w.node_positions
    lever = p[-1, 0] - p[:, 0]
    bending = np.linalg.norm(w.section_moments[:, :2], axis=1)
    expected = np.abs(force[2]) * np.abs(lever)
    scale = expected.max()
    assert scale > 0
    assert np.abs(bending[:-1] - expected[:-1]).max() < 2e-2 * scale  # measured: see the note below
    assert np.abs(w.section_moments[:, 2]).max() < 1e-9 * scale  # a planar load: no twist
    # Axial: the load's component along the tangent d3.
    d3 = w.directors[:, :, 2]
    assert np.allclose(w.section_forces[:-1, 2], (d3[:-1] @ force), atol=2e-2 * np.linalg.norm(force))
    assert np.array_equal(w.section_forces[:, :2], np.zeros((w.node_count, 2)))


def free_fall(nodes=8):
    desc = rod(nodes=nodes, gravity=[0.0, 0.0, -9.81])
    desc["segment"][0]["base"] = "free"
    desc["filter"] = {"enabled": False}
    return haustra.World(desc)


def test_velocities_are_the_last_frames_finite_differences():
    w = free_fall()
    assert not np.any(w.node_velocities) and not np.any(w.angular_velocities)  # before the first step
    rec = w.step(6, record=["node_positions", "node_rotations", "node_velocities", "angular_velocities"])
    dt = w.dt
    assert np.array_equal(rec["node_velocities"][-1], w.node_velocities)
    expected = (rec["node_positions"][-1] - rec["node_positions"][-2]) / dt
    assert np.allclose(w.node_velocities, expected, rtol=0, atol=1e-12)
    # Angular: the rotation vector of R·R₀ᵀ over dt, from the recorded quaternions.
    for k in (0, 3, 7):
        r = quaternion_matrix(rec["node_rotations"][-1, k]) @ quaternion_matrix(rec["node_rotations"][-2, k]).T
        angle = np.arccos(np.clip((np.trace(r) - 1) / 2, -1, 1))
        axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
        vector = axis / (2 * np.sin(angle)) * angle if angle > 1e-12 else axis / 2
        assert np.allclose(w.angular_velocities[k], vector / dt, atol=1e-9)
    w.restore_checkpoint(w.save_checkpoint())
    assert not np.any(w.node_velocities)  # a restore is not a frame's motion


def test_a_recording_equals_reading_every_frame(scenes):
    names = ["node_positions", "strains", "bead_centres", "mesh_positions", "instrument_force", "energy",
             "section_moments", "profile", "contacts"]
    a = haustra.World.from_scene(scenes / "grasp-pull.toml")
    b = haustra.World.from_scene(scenes / "grasp-pull.toml")
    rec = a.step(40, record=names)
    assert rec["node_positions"].shape == (40, a.node_count, 3) and rec["mesh_positions"].dtype == np.float32
    assert list(rec["frame"]) == list(range(1, 41)) and rec["time"][-1] == pytest.approx(40 * a.dt, rel=1e-12)
    for f in range(40):
        b.step()
        assert np.array_equal(rec["node_positions"][f], b.node_positions)
        assert np.array_equal(rec["strains"][f], b.strains)
        assert np.array_equal(rec["bead_centres"][f], b.bead_centres)
        assert np.array_equal(rec["mesh_positions"][f], b.mesh_positions)
        assert np.array_equal(rec["instrument_force"][f, 0], b.instrument(0)["force"])
        e = b.energy
        assert list(rec["energy"][f]) == [e["elastic"], e["gravity"], e["total"]]
        assert np.array_equal(rec["section_moments"][f], b.section_moments)
        assert rec["contacts"][f]["touching"] == b.contacts["touching"]
        p = b.profile
        for key in ("iterations", "substeps", "chords", "newton"):
            assert rec["profile"][f][key] == p[key]
    assert np.all(rec["profile"]["frame_seconds"] > 0)
    assert np.all(rec["profile"]["calls"]["collide"] >= 1)


def test_a_recording_is_refused_up_front():
    w = haustra.World(rod(nodes=10))
    with pytest.raises(haustra.InvalidArgumentError, match="unknown quantity 'positions'; expected any of"):
        w.step(5, record=["positions"])
    with pytest.raises(haustra.InvalidArgumentError, match="more than half"):
        w.step(10**12, record=["node_positions"])
    assert w.frame == 0  # nothing was stepped


def test_an_unstable_frame_raises_with_what_was_recorded():
    desc = rod(nodes=20, youngs_modulus=10.0)  # cannot carry itself (test_world)
    desc["solver"] = {"on_instability": "stop"}
    w = haustra.World(desc)
    with pytest.raises(haustra.UnstableError) as error:
        w.step(500, record=["node_positions"])
    recorded = error.value.recording
    assert len(recorded["frame"]) == w.frame
    if w.frame:
        assert np.array_equal(recorded["node_positions"][-1], w.node_positions)


def step_both(a, b, frames=12):
    a.step(frames)
    b.step(frames)
    return np.array_equal(a.node_positions, b.node_positions)


def test_dt_and_gravity_change_without_a_rebuild_as_if_built_so(scenes):
    changed = haustra.World(rod(nodes=15))
    changed.dt = 0.005
    changed.gravity = [0.0, -3.0, -9.0]
    built = haustra.World(rod(nodes=15, dt=0.005, gravity=[0.0, -3.0, -9.0]))
    assert step_both(changed, built)
    with pytest.raises(haustra.InvalidArgumentError, match="world.dt"):
        changed.dt = -1.0
    assert changed.dt == 0.005


def test_a_coupling_changes_without_a_rebuild_as_if_built_so(scenes):
    over = {"instrument.coupling_stiffness": 300.0, "instrument.coupling_damping": 1.0,
            "instrument.force_limit": 2.0}
    changed = haustra.World.from_scene(scenes / "grasp-push.toml")
    built = haustra.World.from_scene(scenes / "grasp-push.toml", overrides=over)
    changed.set_instrument_coupling(0, 300.0, 1.0, 2.0)
    assert step_both(changed, built, 60)
    with pytest.raises(haustra.InvalidArgumentError, match="rigid"):
        changed.set_instrument_coupling(0, 0.0, 1.0, 2.0)
    with pytest.raises(haustra.InvalidArgumentError, match="force_limit"):
        changed.set_instrument_coupling(0, 300.0, 1.0, -2.0)


def test_a_material_change_keeps_the_mesh_and_copies_with_the_world(scenes):
    import pickle
    small = {"segment.mesh.procedural.vertices": 2000}
    changed = haustra.World.from_scene(scenes / "demo.toml", overrides=small)
    built = haustra.World.from_scene(scenes / "demo.toml", overrides={**small, "segment.youngs_modulus": 1e5,
                                                                     "segment.relaxation_time": 0.5})
    changed.set_material(0, youngs_modulus=1e5, relaxation_time=0.5)
    assert changed.segments[0]["bending_stiffness"] == built.segments[0]["bending_stiffness"]
    copied = pickle.loads(pickle.dumps(changed))
    for w in (changed, built, copied):
        w.step(10)
    assert np.array_equal(changed.node_positions, built.node_positions)
    assert np.array_equal(changed.mesh_positions, built.mesh_positions)
    assert np.array_equal(copied.mesh_positions, built.mesh_positions)
    with pytest.raises(haustra.InvalidArgumentError, match="youngs_modulus"):
        changed.set_material(0, youngs_modulus=-1.0)


def test_viscous_bending_carries_its_rate_moment(scenes):
    # grasp-pull's rod: bending and torsion viscous (η = k × relaxation time, no elastic part), axial
    # elastic. While it moves, m = η (κ − κ₀)/dt with κ₀ the strains the frame started from.
    w = haustra.World.from_scene(scenes / "grasp-pull.toml")
    rec = w.step(45, record=["strains", "section_moments"])
    s = w.segments[0]
    eta = s["bending_stiffness"] * 1.0  # the scene's relaxation time: the default, 1 s
    expected = eta * (rec["strains"][-1, :, :2] - rec["strains"][-2, :, :2]) / w.dt
    scale = np.abs(expected).max()
    assert scale > 0  # it moves
    assert np.abs(w.section_moments[:, :2] - expected).max() < 1e-9 * scale
    assert np.array_equal(rec["section_moments"][-1], w.section_moments)


def test_gravity_is_read_only_and_checked():
    w = haustra.World(rod(nodes=5))
    with pytest.raises(ValueError):
        w.gravity[2] = 0.0  # a copy: writing into it would change nothing, so it refuses
    with pytest.raises(haustra.InvalidArgumentError, match="world.gravity: expected at most 1000"):
        w.gravity = [0.0, 0.0, 1e30]
    assert list(w.gravity) == [0.0, 0.0, -9.81]
    assert "node_positions" in haustra.RECORDABLE and haustra.CONTACT_KINDS[0] == "bead"


def test_a_frame_budget_counts_the_frames_over_it():
    w = haustra.World(rod(nodes=30))
    w.frame_budget = 1e-9  # no frame is that fast: every one is late
    rec = w.step(5, record=["profile"])
    assert w.frame_budget == 1e-9 and w.late_frames == 5 and list(rec["profile"]["late"]) == [1] * 5
    w.frame_budget = 0.0  # off
    w.step(3)
    assert w.late_frames == 5 and w.profile["late"] == 0
