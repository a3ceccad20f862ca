"""Bad input raises haustra.Error subclasses carrying the engine's message: file, line, field."""
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
