"""Bad input raises haustra.Error subclasses carrying the engine's message: file, line, field."""
import numpy as np
import pytest

import haustra
from conftest import rod


def test_missing_scene_file(tmp_path):
    missing = tmp_path / "nope.toml"
    with pytest.raises(haustra.FileError, match="nope.toml") as info:
        haustra.World.from_scene(str(missing))
    assert isinstance(info.value, OSError) and isinstance(info.value, haustra.Error)
    assert info.value.code == "io"


def test_a_folder_or_an_empty_file_is_no_scene(tmp_path):
    # Both once built an empty world that stepped; the command line refused the folder.
    with pytest.raises(haustra.FileError, match="a folder, not a scene file"):
        haustra.World.from_scene(str(tmp_path))
    empty = tmp_path / "empty.toml"
    empty.write_text("  \n")
    with pytest.raises(haustra.FileError, match="empty.toml: the scene file is empty"):
        haustra.World.from_scene(str(empty))


def test_a_surface_given_as_a_scene_says_so(tmp_path):
    # Issue 36: answered with a TOML syntax error on the OBJ's first line.
    surface = tmp_path / "colon.obj"
    surface.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(haustra.ParseError, match=r"colon.obj: a surface \(.obj\), not a scene file: `haustra import"):
        haustra.World.from_scene(str(surface))


def test_a_bad_field_names_file_line_and_field(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text('[world]\ndt = 0.01\n\n[[segment]]\nname = "rod"\nnodes = 20\nyoungs_modulus = -5.0\n')
    with pytest.raises(haustra.Error) as info:
        haustra.World.from_scene(str(scene))
    message = str(info.value)
    assert "bad.toml:7" in message and "youngs_modulus" in message
    assert info.value.field == "segment[0].youngs_modulus"


def test_not_toml(tmp_path):
    scene = tmp_path / "broken.toml"
    scene.write_text("[world\n")
    with pytest.raises(haustra.ParseError, match="broken.toml:1"):
        haustra.World.from_scene(str(scene))


def test_a_bad_dict_names_the_key():
    desc = rod()
    desc["segment"][0]["nodez"] = 5
    with pytest.raises(haustra.Error, match="nodez"):
        haustra.World(desc)
    desc = rod()
    desc["world"]["dt"] = object()
    with pytest.raises(haustra.InvalidArgumentError, match=r"world\.dt: expected a bool, int, float"):
        haustra.World(desc)


def test_a_bad_override_names_it(scenes):
    with pytest.raises(haustra.Error, match="nodes"):
        haustra.World.from_scene(str(scenes / "drop.toml"), overrides={"segment.nodes": -3})
    with pytest.raises(haustra.Error, match="no_such_key"):
        haustra.World.from_scene(str(scenes / "drop.toml"), overrides={"segment.no_such_key": 1})


def test_bad_indices_and_vectors(scenes):
    w = haustra.World.from_scene(str(scenes / "demo.toml"))
    with pytest.raises(haustra.InvalidArgumentError, match="instrument"):
        w.set_instrument_pose(7, [0, 0, 0], [0, 0, 1])
    with pytest.raises(haustra.InvalidArgumentError, match="tip: expected three numbers"):
        w.set_instrument_pose(0, "up", [0, 0, 1])
    with pytest.raises(haustra.InvalidArgumentError, match="triangles"):
        haustra.save_mesh("x.ply", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 5]])


def held_rod_with_a_grasper():
    """rod() with beads, one attachment (its tip) and one instrument: one of each kind of index."""
    desc = rod()
    desc["segment"][0]["beads"] = {"count": 5}
    desc["segment"][0]["attachment"] = [{"node": -1}]
    desc["instrument"] = [{"name": "grasper", "radius": 0.004, "length": 0.3}]
    return desc


@pytest.mark.parametrize("call, arguments, message", [
    ("set_instrument_pose", (3, [0, 0, 0], [0, 0, 1]),
     "set_instrument_pose: instrument 3 is out of range (the world has 1 instrument: 0, or -1 from the end)"),
    ("grasp", (-2,), "grasp: instrument -2 is out of range (the world has 1 instrument: 0, or -1 from the end)"),
    ("release", (1,), "release: instrument 1 is out of range (the world has 1 instrument: 0, or -1 from the end)"),
    ("instrument", (-5,), "instrument: instrument -5 is out of range (the world has 1 instrument: 0, or -1 from the end)"),
    ("set_instrument_coupling", (2, 0.0, 0.0, 0.0),
     "set_instrument_coupling: instrument 2 is out of range (the world has 1 instrument: 0, or -1 from the end)"),
    ("set_external_load", (21, [0, 0, 1]),
     "set_external_load: node 21 is out of range (the world has 21 nodes: 0 to 20, or -21 to -1 from the end)"),
    ("external_load", (-22,),
     "external_load: node -22 is out of range (the world has 21 nodes: 0 to 20, or -21 to -1 from the end)"),
    ("set_material", (1,), "set_material: segment 1 is out of range (the world has 1 segment: 0, or -1 from the end)"),
    ("remove_segment", (-2,),
     "remove_segment: segment -2 is out of range (the world has 1 segment: 0, or -1 from the end)"),
    ("attachment_force", (5, 0),
     "attachment_force: segment 5 is out of range (the world has 1 segment: 0, or -1 from the end)"),
    ("attachment_force", (0, 2),
     "attachment_force: attachment 2 is out of range (segment 0 ('rod') has 2 attachments: 0 to 1, or -2 to -1 "
     "from the end; the last is the instrument's grasp slot)"),
    ("set_attachment_active", (0, -3, False),
     "set_attachment_active: attachment -3 is out of range (segment 0 ('rod') has 2 attachments: 0 to 1, or -2 to -1 "
     "from the end; the last is the instrument's grasp slot)"),
    ("set_attachment_target", (-1, 7, [0, 0, 0]),
     "set_attachment_target: attachment 7 is out of range (segment 0 ('rod') has 2 attachments: 0 to 1, or -2 to -1 "
     "from the end; the last is the instrument's grasp slot)"),
    # Beyond 64 bits (once pybind11's TypeError): the same error, the int's digits whole.
    ("grasp", (2 ** 64,),
     "grasp: instrument 18446744073709551616 is out of range (the world has 1 instrument: 0, or -1 from the end)"),
    ("external_load", (-(10 ** 30),),
     "external_load: node -1000000000000000000000000000000 is out of range (the world has 21 nodes: 0 to 20, or -21 "
     "to -1 from the end)"),
    ("attachment_force", (0, 2 ** 63),
     "attachment_force: attachment 9223372036854775808 is out of range (segment 0 ('rod') has 2 attachments: 0 to 1, "
     "or -2 to -1 from the end; the last is the instrument's grasp slot)"),
])
def test_an_index_out_of_range_names_call_argument_value_and_range(call, arguments, message):
    # Negative ints once gave pybind11's TypeError, indices past the end a message without the call (decision 0088).
    w = haustra.World(held_rod_with_a_grasper())
    with pytest.raises(haustra.InvalidIndexError) as info:
        getattr(w, call)(*arguments)
    assert str(info.value) == message
    assert isinstance(info.value, IndexError) and isinstance(info.value, haustra.InvalidArgumentError)
    assert info.value.code == "invalid_argument" and info.value.field is None


def test_an_index_that_is_not_an_int_is_a_type_error_and_numpy_ints_are_indices():
    w = haustra.World(held_rod_with_a_grasper())
    with pytest.raises(TypeError):
        w.external_load(1.0)
    with pytest.raises(TypeError):
        w.external_load("1")
    force, _ = w.external_load(np.int64(-1))  # __index__, as pybind11's int took
    assert force.shape == (3,)


def test_a_world_without_instruments_says_it_has_none():
    w = haustra.World(rod())
    with pytest.raises(IndexError, match=r"^grasp: instrument 0 is out of range \(the world has no instruments\)$"):
        w.grasp()


def test_negative_indices_count_from_the_end():
    w = haustra.World(held_rod_with_a_grasper())
    w.set_attachment_target(-1, -2, [1.0, 0.0, 0.5])  # segment 0's attachment 0: the tip's
    w.set_instrument_pose(-1, [0.0, 0.0, 2.0], [0.0, 0.0, 1.0])
    assert np.array_equal(w.instrument(-1)["commanded_tip"], [0.0, 0.0, 2.0])
    reference = haustra.World(held_rod_with_a_grasper())
    reference.set_attachment_target(0, 0, [1.0, 0.0, 0.5])
    reference.set_instrument_pose(0, [0.0, 0.0, 2.0], [0.0, 0.0, 1.0])
    w.step(3)
    reference.step(3)
    assert np.array_equal(w.node_positions, reference.node_positions)
    assert np.array_equal(w.attachment_force(-1, -2), reference.attachment_force(0, 0))
    assert np.linalg.norm(reference.attachment_force(0, 0)) > 0
    w.set_material(-1, youngs_modulus=2e6)
    assert w.segments[0]["bending_stiffness"] == pytest.approx(2 * reference.segments[0]["bending_stiffness"])
