"""Python's conventions at the module's edges: bytes-like checkpoints, World(dict, base_dir=...)
with errors that name the key path, pickle and deepcopy that continue bit for bit, Ctrl-C between
frames of step(n), loads that are set or added as the call says."""
import _thread
import copy
import pickle
import threading
import tomllib

import numpy as np
import pytest

import haustra
from conftest import SCENES, rod


def test_checkpoints_restore_from_any_bytes_like_object():
    w = haustra.World(rod(nodes=10))
    w.step(3)
    saved = w.save_checkpoint()
    w.step(4)
    expected = np.array(w.node_positions)
    for data in (bytearray(saved), memoryview(saved), np.frombuffer(saved, dtype=np.uint8)):
        w.restore_checkpoint(data)
        w.step(4)
        assert np.array_equal(w.node_positions, expected)
    with pytest.raises(haustra.InvalidArgumentError, match="bytes-like"):
        w.restore_checkpoint(np.zeros(4, dtype=np.float64))


def two_segment_desc():
    """two-segments.toml as a dict, its mesh obstacle a relative path (assets/bolster.obj)."""
    with open(SCENES / "two-segments.toml", "rb") as f:
        return tomllib.load(f)


def test_a_dict_resolves_its_paths_against_base_dir(tmp_path, monkeypatch):
    desc = two_segment_desc()
    monkeypatch.chdir(tmp_path)  # not where assets/ is
    with pytest.raises(haustra.FileError) as error:
        haustra.World(desc)
    assert str(error.value).startswith("World(desc): environment.mesh[0].file: ")
    assert error.value.field == "environment.mesh[0].file"
    w = haustra.World(desc, base_dir=SCENES)
    reference = haustra.World.from_scene(SCENES / "two-segments.toml")
    w.step(2)
    reference.step(2)
    assert np.array_equal(w.node_positions, reference.node_positions)


def test_a_dicts_errors_name_the_key_path_not_a_generated_line():
    with pytest.raises(haustra.ParseError) as error:
        haustra.World({"segment": [{"nodes": "x"}]})
    assert str(error.value) == 'World(desc): segment[0].nodes: expected an integer, got the string "x"'
    with pytest.raises(haustra.InvalidArgumentError) as error:
        haustra.World({"segment": [{"nodes": 5, "youngs_modulus": -3}]})
    assert str(error.value).startswith("World(desc): segment[0].youngs_modulus: expected a positive")


@pytest.mark.parametrize("duplicate", [pickle.loads, copy.deepcopy, copy.copy])
def test_a_copy_continues_bit_for_bit(duplicate, scenes):
    w = haustra.World.from_scene(scenes / "grasp-pull.toml")
    w.step(20)  # mid-grasp: instruments, attachments and the filter all carry state
    w.set_external_load(-1, force=[0.0, 0.01, 0.0])
    w.gravity = [0.0, 0.0, -5.0]
    other = duplicate(pickle.dumps(w)) if duplicate is pickle.loads else duplicate(w)
    assert other is not w and other.frame == w.frame and list(other.gravity) == [0.0, 0.0, -5.0]
    w.step(15)
    other.step(15)
    assert np.array_equal(w.node_positions, other.node_positions)
    assert np.array_equal(w.mesh_positions, other.mesh_positions)
    assert np.array_equal(w.instrument(0)["force"], other.instrument(0)["force"])


def test_a_world_from_a_dict_pickles_too():
    w = haustra.World(rod(nodes=12))
    w.step(5)
    other = pickle.loads(pickle.dumps(w))
    w.step(5)
    other.step(5)
    assert np.array_equal(w.node_positions, other.node_positions)


def test_a_world_whose_segments_changed_refuses_to_pickle():
    w = haustra.World(rod(nodes=12))
    w.add_segment({"name": "extra", "nodes": 5, "rest": {"length": 0.2}, "base_position": [0, 1, 0]})
    with pytest.raises(haustra.InvalidArgumentError, match="segments were added or removed"):
        pickle.dumps(w)


def test_ctrl_c_stops_step_between_frames():
    # A step of 10 million frames (minutes); an interrupt arrives while it runs. The assertions hold
    # whenever it arrives: the world is at a whole frame and steps on from there.
    w = haustra.World(rod(nodes=10))
    timer = threading.Timer(0.2, _thread.interrupt_main)
    timer.start()
    with pytest.raises(KeyboardInterrupt) as interrupt:
        w.step(10_000_000, record=["node_positions"])
    timer.join()
    done = w.frame
    assert 0 < done < 10_000_000
    recorded = interrupt.value.recording
    assert len(recorded["frame"]) == done and recorded["frame"][-1] == done
    assert np.array_equal(recorded["node_positions"][-1], w.node_positions)
    assert w.time == pytest.approx(done * w.dt, rel=1e-12)
    w.step(2)
    assert w.frame == done + 2


def test_loads_are_set_or_added_as_the_call_says(scenes):
    w = haustra.World.from_scene(scenes / "cantilever.toml")  # the scene loads its last node
    scene_force, _ = w.external_load(-1)
    assert np.linalg.norm(scene_force) > 0
    w.add_external_load(-1, force=[1.0, 0.0, 0.0], moment=[0.0, 0.0, 0.5])
    force, moment = w.external_load(-1)
    assert np.array_equal(force, scene_force + [1.0, 0.0, 0.0]) and np.array_equal(moment, [0.0, 0.0, 0.5])
    w.set_external_load(-1, force=[0.0, 0.0, 2.0])
    force, moment = w.external_load(-1)
    assert np.array_equal(force, [0.0, 0.0, 2.0]) and np.array_equal(moment, [0.0, 0.0, 0.0])
    with pytest.raises(haustra.InvalidArgumentError, match="out of range"):
        w.external_load(w.node_count)


def test_a_dict_takes_paths_and_names_a_value_it_cannot_take():
    desc = two_segment_desc()
    desc["environment"]["mesh"][0]["file"] = SCENES / "assets" / "bolster.obj"  # a pathlib.Path
    assert haustra.World(desc).node_count > 0
    desc["environment"]["mesh"][0]["file"] = None
    with pytest.raises(haustra.InvalidArgumentError) as error:
        haustra.World(desc)
    assert str(error.value) == "World(desc): environment.mesh[0].file: expected a bool, int, float, str (or path), " \
                               "list or dict, got NoneType"
    assert error.value.field == "environment.mesh[0].file"


def skinned_organ(key=None, value=None):
    """A cantilever with beads 2 cm apart and a procedural organ; segment.mesh[key] = value when given."""
    desc = rod(nodes=41)
    segment = desc["segment"][0]
    segment["rest"]["length"] = 0.4
    segment["beads"] = {"count": 20}
    segment["mesh"] = {"source": "procedural", "procedural": {"vertices": 1500}}
    if key is not None:
        segment["mesh"][key] = value
    return desc


@pytest.mark.parametrize("skin", ["cage", "cage-full"])
def test_a_dicts_skin_gives_the_scene_files_world(tmp_path, skin):
    # decision 0120's one choice, in a dict as in a scene file: the same bits, nodes and mesh.
    scene = tmp_path / "skinned.toml"
    with open(scene, "w") as f:
        f.write('[world]\ndt = 0.01\nthreads = 1\n[[segment]]\nname = "rod"\nnodes = 41\nyoungs_modulus = 1e6\n'
                '[segment.rest]\nlength = 0.4\n[segment.beads]\ncount = 20\n[segment.mesh]\nsource = "procedural"\n'
                f'skinning = "{skin}"\n[segment.mesh.procedural]\nvertices = 1500\n')
    worlds = [haustra.World(skinned_organ("skinning", skin)), haustra.World.from_scene(scene),
              haustra.World(skinned_organ())]
    for w in worlds:
        w.step(20)
    chosen, from_file, default = worlds
    assert np.array_equal(chosen.node_positions, from_file.node_positions)
    assert np.array_equal(chosen.mesh_positions, from_file.mesh_positions)
    assert np.array_equal(chosen.mesh_normals, from_file.mesh_normals)
    assert not np.array_equal(chosen.mesh_positions, default.mesh_positions)  # along the rod: another skin


@pytest.mark.parametrize("key,value", [("rings_per_vertex", 4), ("weight_left_out", 0.02),
                                       ("max_rings_per_vertex", 7), ("mean_rings_per_vertex", 7),
                                       ("skin_cost_limit", 2)])
def test_a_removed_localization_key_is_refused_naming_the_key_to_use(key, value):
    with pytest.raises(haustra.ParseError) as error:
        haustra.World(skinned_organ(key, value))
    assert f"segment[0].mesh.{key}: this key was removed (decision 0120): " \
           'choose mesh.skinning = "along-rod" | "cage" | "cage-full" | "linear-blend"' in str(error.value)
    assert error.value.field == f"segment[0].mesh.{key}"
