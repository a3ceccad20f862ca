"""haustra.studies on Dask: a 2-worker local cluster equals serial row for row; a killed worker loses and
duplicates nothing; a stopped study resumes with only the missing cells; a bad override is its row's error."""
import functools
import os
import pathlib
import sys

import cloudpickle
import pytest

import haustra
from haustra import studies

SOURCE = pathlib.Path(os.environ.get("HAUSTRA_SOURCE", pathlib.Path(__file__).parents[2])).resolve()
GRASP_PULL = SOURCE / "scenes" / "grasp-pull.toml"

# 3 stiffnesses × 2 iteration counts × 2 protocols = 12 cells of 20 frames of scenes/grasp-pull.toml.
TWELVE_CELLS = f"""
[study]
name = "twelve"
frames = 20
reference = "segment.youngs_modulus=100000.0,solver.iterations=2"
[grid]
scenes = ["{GRASP_PULL}"]
protocols = ["scripted", "grasp-and-lift"]
[sweep]
"segment.youngs_modulus" = [20000.0, 50000.0, 100000.0]
"solver.iterations" = [1, 2]
"""

# The workers unpickle the cell functions below by value: this test module is not importable there.
cloudpickle.register_pickle_by_value(sys.modules[__name__])


def write_study(folder, text):
    path = pathlib.Path(folder) / "study.toml"
    path.write_text(text)
    return studies.load_study(path)


def deterministic_rows(rows):
    return [studies.deterministic(r) for r in rows]


@pytest.fixture(scope="module")
def serial_rows(tmp_path_factory):
    folder = tmp_path_factory.mktemp("serial")
    study = write_study(folder, TWELVE_CELLS)
    result = studies.run_study(study, folder / "out", serial=True, show_progress=False)
    assert result["ran"] == 12 and result["failed"] == 0
    return result["rows"]


def test_the_serial_rows_measure_the_runs(serial_rows):
    keys = [r["key"] for r in serial_rows]
    assert len(set(keys)) == 12
    assert all(r["engine_version"] == haustra.__version__ and r["finite"] == "true" for r in serial_rows)
    lifts = [float(r["lift_m"]) for r in serial_rows if r["protocol"] == "grasp-and-lift"]
    # 20 frames of 1/60 s of a 1 s lift of 2 cm: the grasped node rises, by less than the jaws did.
    assert all(0.0 < lift < 0.02 * 20 / 60 + 1e-3 for lift in lifts), lifts
    # A softer rod sags differently: the settings change the numbers.
    assert len({r["tip_z"] for r in serial_rows if r["protocol"] == "scripted"}) == 6


def test_a_two_worker_local_cluster_gives_the_serial_rows(tmp_path, serial_rows):
    study = write_study(tmp_path, TWELVE_CELLS)
    result = studies.run_study(study, tmp_path / "out", workers=2, show_progress=False)
    assert result["ran"] == 12
    assert deterministic_rows(result["rows"]) == deterministic_rows(serial_rows)


def crash_once(cell, marker, victim):
    """The victim cell kills its own worker process on its first attempt (the marker file says it did)."""
    if cell["key"] == victim and not pathlib.Path(marker).exists():
        pathlib.Path(marker).write_text(str(os.getpid()))
        os._exit(9)
    return studies.run_cell(cell)


def test_a_worker_killed_mid_study_loses_and_duplicates_nothing(tmp_path, serial_rows):
    study = write_study(tmp_path, TWELVE_CELLS)
    marker = tmp_path / "killed"
    runner = functools.partial(crash_once, marker=str(marker), victim=study.cells[5]["key"])
    result = studies.run_study(study, tmp_path / "out", workers=2, cell_runner=runner, show_progress=False)
    assert marker.exists() and int(marker.read_text()) != os.getpid()  # a worker process died
    assert result["ran"] == 12
    written = studies.read_rows(tmp_path / "out" / "results.csv")
    assert sorted(r["key"] for r in written) == sorted(c["key"] for c in study.cells)  # each exactly once
    assert deterministic_rows(written) == deterministic_rows(serial_rows)


class Stopped(BaseException):
    """A stop (Ctrl-C, a job's time limit) after some cells: not a cell failure."""


def stop_after(count, ran):
    def runner(cell):
        if len(ran) == count:
            raise Stopped()
        ran.append(cell["key"])
        return studies.run_cell(cell)
    return runner


def test_a_stopped_study_runs_only_its_missing_cells_again(tmp_path, serial_rows):
    study = write_study(tmp_path, TWELVE_CELLS)
    first = []
    with pytest.raises(Stopped):
        studies.run_study(study, tmp_path / "out", serial=True, cell_runner=stop_after(5, first), show_progress=False)
    assert len(studies.read_rows(tmp_path / "out" / "results.csv")) == 5
    second = []
    result = studies.run_study(study, tmp_path / "out", serial=True, cell_runner=stop_after(99, second),
                               show_progress=False)
    assert result["skipped"] == 5 and result["ran"] == 7
    assert sorted(first + second) == sorted(c["key"] for c in study.cells) and not set(first) & set(second)
    assert deterministic_rows(result["rows"]) == deterministic_rows(serial_rows)


def test_a_bad_override_is_its_rows_error_and_the_others_complete(tmp_path):
    study = write_study(tmp_path, f"""
[study]
name = "bad"
frames = 5
[grid]
scenes = ["{GRASP_PULL}"]
[[setting]]
name = "default"
[[setting]]
name = "negative stiffness"
overrides = {{ "segment.youngs_modulus" = -1.0 }}
[[setting]]
name = "fewer iterations"
overrides = {{ "solver.iterations" = 1 }}
""")
    result = studies.run_study(study, tmp_path / "out", serial=True, show_progress=False)
    rows = {r["setting"]: r for r in result["rows"]}
    with pytest.raises(haustra.Error) as engine:
        haustra.World.from_scene(GRASP_PULL, overrides={"segment.youngs_modulus": -1.0, "world.threads": 1})
    assert rows["negative stiffness"]["status"] == "failed"
    assert rows["negative stiffness"]["error"] == str(engine.value).strip().splitlines()[0]
    assert "youngs_modulus" in rows["negative stiffness"]["error"]
    assert [rows[s]["status"] for s in ("default", "fewer iterations")] == ["ok", "ok"]
    assert rows["default"]["frames"] == "5"


def test_a_study_file_with_an_unknown_protocol_names_the_field(tmp_path):
    with pytest.raises(studies.StudyError, match=r"grid.protocols: 'wobble' is not a protocol"):
        write_study(tmp_path, f'[grid]\nscenes = ["{GRASP_PULL}"]\nprotocols = ["wobble"]\n')


def test_stability_cells_through_dask_give_the_committed_map(tmp_path):
    """The stability map's cells at N ≤ 20 (240 of 516) as a Dask study on 2 workers: outcomes equal to
    tests/data/stability-map.csv, the table `make stability-doc` writes (the whole map: make studies-check)."""
    study = write_study(tmp_path, '[study]\nname = "stability"\nkind = "stability"\n')
    study.cells = [c for c in study.cells if c["setting"].startswith(("N=2 ", "N=20 "))]
    result = studies.run_study(study, tmp_path / "out", workers=2, show_progress=False)
    mine = [f"{r['nodes']},{float(r['youngs_modulus']):g},{float(r['dt']):g},{r['load']},{r['law']},{r['outcome']},"
            f"{r['fast_outcome']}" for r in result["rows"]]
    with open(SOURCE / "tests" / "data" / "stability-map.csv") as f:
        committed = [line.strip() for line in f if line.split(",")[0] in ("2", "20")]
    assert len(mine) == 240 and mine == committed


def test_an_unknown_tradeoff_knob_is_refused_with_the_known_ones():
    with pytest.raises(haustra.InvalidArgumentError, match=r"no knob 'wobble' \(expected one of 'nodes per segment'"):
        haustra._haustra._studies.run_tradeoff_knob("wobble")


def test_a_setting_removed_from_the_file_keeps_its_rows(tmp_path, serial_rows):
    study = write_study(tmp_path, TWELVE_CELLS)
    studies.run_study(study, tmp_path / "out", serial=True, show_progress=False)
    fewer = write_study(tmp_path, TWELVE_CELLS.replace("[20000.0, 50000.0, 100000.0]", "[50000.0, 100000.0]"))
    result = studies.run_study(fewer, tmp_path / "out", serial=True, show_progress=False)
    assert result["ran"] == 0 and result["skipped"] == 8 and len(result["rows"]) == 8
    assert len(studies.read_rows(tmp_path / "out" / "results.csv")) == 12  # the other 4 still there, after


def test_grasp_and_lift_measures_the_grasped_node_of_a_chain(tmp_path):
    """scenes/bowel.toml is 32 chained segments: the grasped node's index is its segment's own, and the lift is
    read at its world index (the jaws rise 2 cm × 20/60 ≈ 6.7 mm in 20 frames; the tissue follows most of it)."""
    study = write_study(tmp_path, f'[study]\nframes = 20\n[grid]\nscenes = ["{SOURCE / "scenes" / "bowel.toml"}"]\n'
                                  'protocols = ["grasp-and-lift"]\n')
    row = studies.run_study(study, tmp_path / "out", serial=True, show_progress=False)["rows"][0]
    assert row["status"] == "ok", row["error"]
    assert 0.5 * 0.02 * 20 / 60 < float(row["lift_m"]) <= 0.02 * 20 / 60 + 1e-3


SLOW_CELLS = f"""
[study]
name = "slow"
frames = 6000
[grid]
scenes = ["{GRASP_PULL}"]
[sweep]
"segment.youngs_modulus" = [20000.0, 30000.0, 40000.0, 50000.0, 60000.0, 70000.0]
"""


@pytest.mark.parametrize("where", [["--serial"], ["--workers", "1"]])
def test_ctrl_c_stops_a_study_and_keeps_its_rows(tmp_path, where):
    """Ctrl-C (SIGINT to the process group, as a terminal sends it) stops the study within seconds, keeps the
    rows written, says so and exits 130; the same command then runs only the cells left."""
    import signal
    import subprocess
    import time
    (tmp_path / "study.toml").write_text(SLOW_CELLS)
    command = [sys.executable, "-m", "haustra.studies", "run", "study.toml", *where, "--out", "out"]
    process = subprocess.Popen(command, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    table = tmp_path / "out" / "results.csv"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(studies.read_rows(table)) < 1:
        time.sleep(0.2)
    os.killpg(process.pid, signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stderr
    kept = len(studies.read_rows(table))
    assert 1 <= kept < 6
    assert f"the {kept} rows written are kept" in stderr and "Traceback" not in stderr
    again = studies.run_study(studies.load_study(tmp_path / "study.toml"), tmp_path / "out", serial=True,
                              show_progress=False)
    assert again["skipped"] == kept and again["ran"] == 6 - kept


APPENDIX = SOURCE / "tests" / "data" / "anatomy" / "HuBMAPVHM-00070-large-intestine-Appendix.obj"


def test_a_surface_study_measures_the_organ_and_a_resume_reuses_its_import(tmp_path):
    """An imported organ through the organ protocol (decision 0097: left alone 10 s, pulled 5 cm sideways, held,
    released): its drift at rest, the grasp's travel and force, per setting; the import's own protocol row. Run
    again after a stop, the study reuses the import it made (the `haustra` command is not run again)."""
    surfaces = tmp_path / "surfaces"
    surfaces.mkdir()
    os.symlink(APPENDIX, surfaces / APPENDIX.name)
    study = write_study(tmp_path, '[study]\nname = "organ"\n[grid]\nsurfaces = "surfaces"\nprotocols = ["organ"]\n'
                                  '[[setting]]\nname = "as imported"\n[[setting]]\nname = "stiff ×3"\n'
                                  'overrides = { "segment.youngs_modulus" = 99600.0 }\n')
    with pytest.raises(Stopped):
        studies.run_study(study, tmp_path / "out", serial=True, cell_runner=stop_after(1, []), show_progress=False)
    assert len(studies.read_rows(tmp_path / "out" / "results.csv")) == 1
    broken = tmp_path / "no-haustra"
    broken.write_text("#!/bin/sh\nexit 3\n")
    broken.chmod(0o755)
    os.environ["HAUSTRA_BIN"], saved = str(broken), os.environ.get("HAUSTRA_BIN")
    try:
        result = studies.run_study(study, tmp_path / "out", serial=True, show_progress=False)
    finally:
        os.environ["HAUSTRA_BIN"] = saved
    rows = result["rows"]
    assert [r["status"] for r in rows] == ["ok", "ok"], [r["error"] for r in rows]
    assert rows[1]["import_reused"] == "true"
    for r in rows:
        # The import's own run of the protocol (docs/anatomy.md's row for this surface): it holds.
        assert r["protocol_outcome"].startswith("holds") and float(r["protocol_pulled_mm"]) > 20
        # This cell's run of it: the organ stays within a millimetre left alone, the grasp moves its node most of
        # the 5 cm pulled, the force stays under the grasper's limit.
        assert float(r["drift_rest_max_mm"]) < 1.0  # measured 0.064
        assert 20 < float(r["grasp_moved_mm"]) < 55  # measured 38.1 and 48.3
        assert 0 < float(r["force_max_N"]) < 20  # measured 1.11 and 1.84
    # The cell as imported is the import's own protocol, measured in Python: the same travel and force as the C++
    # row (which prints them rounded to 0.1 mm and 0.01 N); stiffer tissue follows the grasp further, harder.
    imported, stiff = rows
    assert abs(float(imported["grasp_moved_mm"]) - float(imported["protocol_pulled_mm"])) <= 0.06
    assert abs(float(imported["force_max_N"]) - float(imported["protocol_force_N"])) <= 0.006
    assert float(stiff["grasp_moved_mm"]) > float(imported["grasp_moved_mm"])
    assert float(stiff["force_max_N"]) > float(imported["force_max_N"])


STOPPED_STUDY = '''"""A study on 2 local workers whose first cell runs and whose others wait for ever (test_studies.py)."""
import pathlib
import sys
import time

from haustra import studies


def first_only(cell, first):
    if cell["key"] != first:
        time.sleep(24 * 3600)  # until the stop kills the worker
    return studies.run_cell(cell)


if __name__ == "__main__":
    import functools
    import cloudpickle
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    study = studies.load_study(pathlib.Path(sys.argv[1]))
    result = studies.run_study(study, sys.argv[2], workers=2, show_progress=False,
                               cell_runner=functools.partial(first_only, first=study.cells[0]["key"]))
    sys.exit(130 if result["interrupted"] else 0)
'''


def processes_in_group(group):
    """The live processes of a process group (from /proc)."""
    found = []
    for stat in pathlib.Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == group and fields[0] != "Z":
            found.append(int(stat.parent.name))
    return found


@pytest.mark.parametrize("stop", ["SIGINT", "SIGTERM"])
def test_a_signal_stops_a_dask_study_its_workers_with_it_keeping_its_rows(tmp_path, stop):
    """Ctrl-C (SIGINT, here to the study's process alone) or a batch system's SIGTERM stops a study on a local
    cluster even while its workers are busy: the process exits, its worker processes with it, and the rows written
    stay (issue 36). No clock: the test waits for the first row, signals, and waits for the exit."""
    import signal
    import subprocess
    import time
    study = tmp_path / "study.toml"
    study.write_text(TWELVE_CELLS)
    script = tmp_path / "stopped_study.py"
    script.write_text(STOPPED_STUDY)
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.Popen([sys.executable, str(script), str(study), str(out)], env=env, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    table = out / "results.csv"
    while len(studies.read_rows(table)) < 1:  # the first cell's row; the others never come
        assert proc.poll() is None, proc.stdout.read().decode()
        time.sleep(0.2)
    os.kill(proc.pid, getattr(signal, stop))
    output = proc.communicate()[0].decode()
    assert proc.returncode == 130, output
    # A process told to stop takes a moment to be gone (a killed worker, multiprocessing's resource
    # tracker reading the end of its pipe): look again, a bounded number of times, then none may be left.
    left = processes_in_group(proc.pid)
    for _ in range(100):
        if not left:
            break
        time.sleep(0.1)
        left = processes_in_group(proc.pid)
    assert left == [], [pathlib.Path(f"/proc/{p}/cmdline").read_bytes().replace(b"\0", b" ")[:200] for p in left]
    rows = studies.read_rows(table)
    assert [r["key"] for r in rows] == [studies.load_study(study).cells[0]["key"]]
    assert rows[0]["status"] == "ok"
