"""haustra.Batch (decision 0103): many worlds stepped in one call, each the same bits as stepped alone."""
import _thread
import threading

import numpy as np
import pytest

import haustra
from conftest import rod


def rollout_worlds(count, nodes=15):
    """Rods that differ: each its own tip load, so no two worlds are alike."""
    worlds = []
    for i in range(count):
        w = haustra.World(rod(nodes=nodes))
        w.set_external_load(-1, [0.0, 0.01 * i, -0.02 * (i % 3)])
        worlds.append(w)
    return worlds


@pytest.mark.parametrize("threads", [1, 2])
def test_a_batch_steps_each_world_as_alone(threads):
    alone, batched = rollout_worlds(7), rollout_worlds(7)
    for w in alone:
        w.step(12)
    batch = haustra.Batch(batched, threads=threads)
    assert len(batch) == 7 and batch.threads == threads and batch.worlds[3] is batched[3]
    assert batch.step(12) is None
    for a, b in zip(alone, batched):
        assert a.frame == b.frame == 12
        assert np.array(a.node_positions).tobytes() == np.array(b.node_positions).tobytes()
        assert np.array(a.strains).tobytes() == np.array(b.strains).tobytes()


def test_a_batch_records_each_world_as_its_own_step_does():
    alone, batched = rollout_worlds(4), rollout_worlds(4)
    expected = [w.step(6, record=["node_positions", "energy"]) for w in alone]
    recordings = haustra.Batch(batched, threads=2).step(6, record=["node_positions", "energy"])
    assert len(recordings) == 4
    for e, r in zip(expected, recordings):
        assert r["node_positions"].shape == (6, 15, 3)
        assert np.array_equal(e["node_positions"], r["node_positions"])
        assert np.array_equal(e["frame"], r["frame"]) and np.array_equal(e["energy"], r["energy"])


def test_a_batch_refuses_what_it_cannot_step():
    w = haustra.World(rod())
    with pytest.raises(haustra.InvalidArgumentError, match="a world appears twice"):
        haustra.Batch([w, w])
    with pytest.raises(haustra.InvalidArgumentError, match="expected a list of haustra.World, got a int"):
        haustra.Batch([w, 3])
    with pytest.raises(haustra.InvalidArgumentError, match=r"Batch.step\(n\): expected n >= 0, got -1"):
        haustra.Batch([w]).step(-1)
    with pytest.raises(haustra.InvalidArgumentError, match="unknown"):
        haustra.Batch([w]).step(2, record=["no such thing"])
    assert w.frame == 0


def test_a_world_that_fails_stops_alone_and_its_error_names_it():
    worlds = rollout_worlds(3)
    worlds[1].set_external_load(-1, [0.0, 0.0, -1e5])  # the most a load may be, far past what the rod holds: unstable
    with pytest.raises(haustra.UnstableError) as failed:
        haustra.Batch(worlds, threads=2).step(20)
    assert failed.value.world == 1
    assert failed.value.frames[0] == 20 and failed.value.frames[2] == 20 and failed.value.frames[1] < 20
    assert worlds[0].frame == 20 and worlds[2].frame == 20


def test_ctrl_c_stops_a_batch_between_frames():
    worlds = rollout_worlds(4, nodes=10)
    timer = threading.Timer(0.2, _thread.interrupt_main)
    timer.start()
    with pytest.raises(KeyboardInterrupt) as interrupt:
        haustra.Batch(worlds, threads=2).step(10_000_000)
    timer.join()
    frames = interrupt.value.frames
    assert [w.frame for w in worlds] == frames
    assert all(f < 10_000_000 for f in frames) and sum(frames) > 0
    worlds[0].step(1)  # the worlds are free again
