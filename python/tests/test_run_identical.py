"""A Python-driven run gives the bits `haustra run` gives for the same scene."""
import json
import subprocess

import numpy as np

import haustra


def test_python_run_matches_haustra_run(scenes, haustra_bin, tmp_path):
    frames = 90
    done = subprocess.run([haustra_bin, "run", str(scenes / "drop.toml"), "--frames", str(frames), "--quiet",
                           "--out", str(tmp_path)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    with open(tmp_path / "summary.json") as f:
        summary = json.load(f)
    cli = np.array(summary["segments"][0]["final_node_positions_m"])  # JSON keeps every bit of a double

    w = haustra.World.from_scene(str(scenes / "drop.toml"))
    w.step(frames)
    assert w.threads == summary["threads"]
    assert np.array_equal(w.node_positions, cli)
