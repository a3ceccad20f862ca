"""What one cell does: build its world, run a protocol, measure, return a row (a dict). Runs in any process."""
import json
import os
import pathlib
import shutil
import subprocess
import tempfile
import time

import numpy as np

from .. import _haustra

# Columns whose values are wall-clock measurements: they differ between runs and machines, so the
# determinism checks (and the comparison with `make study`) leave them out. Every other column of a
# row is the same bits on 1 worker, 2 workers or in-process.
TIMING_COLUMNS = {"frame_ms_median", "frame_ms_p99", "cell_s", "import_s", "import_task_s", "anatomy_frame_ms",
                  "knob_measured"}

KEY_COLUMNS = ["key", "scene_name", "scene_hash", "setting", "overrides", "protocol", "engine_version", "status",
               "error"]
GRID_METRICS = ["frames", "finite", "tip_x", "tip_y", "tip_z", "lift_m", "force_max_N",
                "force_jump_max_N", "penetration_max_m", "bead_overlap_max_m", "energy_change_J", "recovered",
                "unstable", "frame_ms_median", "frame_ms_p99", "cell_s"]
# The import's report (the row `haustra anatomy` writes for the surface): in a surface study's rows.
IMPORT_COLUMNS = ["import_repairs", "import_organ", "import_units", "import_open_ends", "import_length_mm",
                  "import_nodes", "import_beads", "import_rings", "import_s", "import_outside", "import_crossing",
                  "anatomy_lift_mm", "anatomy_skin_err_mm", "anatomy_frame_ms", "anatomy_outcome", "import_task_s"]
LIFT_SECONDS, LIFT_HEIGHT = 1.0, 0.02  # grasp-and-lift: 2 cm in the first second, then held


def first_line(text):
    return str(text).strip().splitlines()[0] if str(text).strip() else type(text).__name__


def percentile(values, p):
    """The same rank rule as the engine's tables (nearest rank, rounded)."""
    if not values:
        return float("nan")
    v = sorted(values)
    return v[min(len(v) - 1, int(p * (len(v) - 1) + 0.5))]


def _grasp_from_above(world):
    """grasp-and-lift: instrument 0 taken from its script, put 3 mm above the bead nearest the middle
    node, its jaws closed. Returns the start tip and axis."""
    if world.instrument_count == 0:
        raise _haustra.InvalidArgumentError("grasp-and-lift: the scene has no [[instrument]] to grasp with "
                                            "(expected at least one)")
    if world.bead_count == 0:
        raise _haustra.InvalidArgumentError("grasp-and-lift: the scene has no beads to grasp (expected segment.beads)")
    nodes = np.asarray(world.bead_nodes, dtype=np.int64)
    nearest = int(np.argmin(np.abs(nodes - world.node_count // 2)))
    centre = np.array(world.bead_centres[nearest])
    axis = np.array([0.0, 0.0, 1.0])
    tip = centre + (float(world.bead_radii[nearest]) + 0.003) * axis
    world.set_instrument_pose(0, tip, axis)
    world.grasp(0)
    return tip, axis


def run_scene_cell(cell):
    """A grid cell: the scene (or the imported surface's grasp scene) with the cell's overrides, through its
    protocol, measured frame by frame."""
    overrides = json.loads(cell["overrides"])
    world = _haustra.World.from_scene(cell["scene"], overrides=overrides)
    frames = cell["frames"] if cell["frames"] is not None else world.scene_frames
    lifting = cell["protocol"] == "grasp-and-lift"
    tip0 = axis = start = None
    if lifting:
        tip0, axis = _grasp_from_above(world)
    frame_seconds, forces, energies = [], [], []
    grasped_node, lift = None, float("nan")
    for _ in range(frames):
        if lifting:
            t = min(1.0, (world.time + world.dt) / LIFT_SECONDS)
            world.set_instrument_pose(0, tip0 + np.array([0.0, 0.0, LIFT_HEIGHT * t]), axis)
        world.step(1)
        frame_seconds.append(world.profile["frame_seconds"])
        energies.append(world.energy["total"])
        if world.instrument_count:
            state = world.instrument(0)
            forces.append(np.array(state["force"]))
            if state["grasping"] and grasped_node is None:  # its node index is the segment's own
                grasped_node = world.segments[state["grasped_segment"]]["node_offset"] + state["grasped_node"]
                start = float(world.node_positions[grasped_node][2])
    if grasped_node is not None:
        lift = float(world.node_positions[grasped_node][2]) - start
    positions = np.array(world.node_positions)
    magnitudes = [float(np.linalg.norm(f)) for f in forces]
    jumps = [float(np.linalg.norm(b - a)) for a, b in zip(forces, forces[1:])]
    contacts = world.contacts
    events = world.events
    tip = positions[-1]
    return {
        "frames": frames, "finite": bool(np.isfinite(positions).all()),
        "tip_x": float(tip[0]), "tip_y": float(tip[1]), "tip_z": float(tip[2]), "lift_m": lift,
        "force_max_N": max(magnitudes, default=0.0), "force_jump_max_N": max(jumps, default=0.0),
        "penetration_max_m": float(contacts["max_environment_depth"]),
        "bead_overlap_max_m": float(contacts["max_bead_overlap"]),
        "energy_change_J": (energies[-1] - energies[0]) if energies else 0.0,
        "recovered": sum(e["kind"] == "recovered" for e in events),
        "unstable": sum(e["kind"] != "recovered" for e in events),
        "frame_ms_median": 1e3 * percentile(frame_seconds, 0.5), "frame_ms_p99": 1e3 * percentile(frame_seconds, 0.99),
    }


def haustra_command():
    """The `haustra` command line (the import runs it): $HAUSTRA_BIN, else the one built with this package
    (inside it when installed, the build tree's bin/ otherwise), else `haustra` on PATH."""
    from .._command import program
    found = os.environ.get("HAUSTRA_BIN") or program() or shutil.which("haustra")
    if not found or not os.access(found, os.X_OK):
        raise FileNotFoundError("importing a surface runs `haustra anatomy`: set HAUSTRA_BIN to the haustra "
                                "executable (build/release/bin/haustra) or put it on PATH")
    return found


def parse_anatomy_row(markdown, name):
    """The surface's row of the table `haustra anatomy` prints, by the table's own header."""
    lines = [ln for ln in markdown.splitlines() if ln.startswith("| ")]
    header = [h.strip() for h in lines[0].strip("|").split(" | ")]
    for line in lines[1:]:  # the |---| line does not start with "| "
        values = [v.strip() for v in line.strip().strip("|").split(" | ")]
        if values[0] == name:
            return dict(zip(header, values))
    raise RuntimeError(f"haustra anatomy: no row for '{name}' in its table")


def import_surface(surface, out, threads=1):
    """Imports one surface as `make anatomy` does (the same C++ run: `haustra anatomy` on a folder holding
    only it), its world on `threads` threads (a study's cells' own: one per worker's core, the same bits);
    returns the import report fields and the grasp scene written beside the imported scene."""
    surface = pathlib.Path(surface)
    out = pathlib.Path(out)
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="haustra-import-") as folder:
        for part in [surface, surface.with_name(surface.stem + "-centreline.json")]:
            if part.exists():
                os.symlink(part, pathlib.Path(folder) / part.name)
        done = subprocess.run([haustra_command(), "anatomy", folder, "--out", str(out), "--threads", str(threads)],
                              capture_output=True, text=True)
    if done.returncode != 0 and "| surface |" not in done.stdout:
        raise RuntimeError(f"haustra anatomy {surface.name}: exit {done.returncode}: {first_line(done.stderr)}")
    row = parse_anatomy_row(done.stdout, surface.stem)
    frame = row.get("frame ms (p99)", "")
    report = {"import_repairs": row.get("repairs", ""), "import_organ": row.get("organ", ""),
              "import_units": row.get("units", ""), "import_open_ends": row.get("open ends", ""),
              "import_length_mm": row.get("length mm", ""), "import_nodes": row.get("nodes", ""),
              "import_beads": row.get("beads", ""), "import_rings": row.get("rings", ""),
              "import_s": row.get("import s", ""), "import_outside": row.get("outside", ""),
              "import_crossing": row.get("crossing", ""), "anatomy_lift_mm": row.get("lift mm", ""),
              "anatomy_skin_err_mm": row.get("skin err mm", ""), "anatomy_frame_ms": frame.split(" ")[0],
              "anatomy_outcome": row.get("outcome", "")}
    scene = out / surface.stem / "grasp.toml"
    if not scene.is_file():
        raise RuntimeError(f"{surface.name}: not imported ({report['anatomy_outcome']}): no {scene}")
    return {"scene": str(scene), "report": report, "seconds": time.perf_counter() - started}


def run_empty_cell(cell):
    """Nothing: the scheduling overhead alone (bench: per-cell cost of the scheduler)."""
    return {"frames": 0}


# A stability-map cell and a trade-off knob: the C++ functions the `haustra stability` and
# `haustra study` sweeps themselves run (studies/src), one per task.
def run_stability_cell(cell):
    return _haustra._studies.run_stability_cell(json.loads(cell["params"]), cell["large_n"])


def run_tradeoff_cell(cell):
    knob = _haustra._studies.run_tradeoff_knob(cell["knob"])
    errors = [[r["setting"], r["error"]] for r in knob["rows"]]  # deterministic; costs are timings
    return {"settings_errors": json.dumps(errors), "knob_measured": json.dumps(knob)}


GRID_PROTOCOLS = ["scripted", "grasp-and-lift"]  # what a grid study's cells may run
PROTOCOLS = {"scripted": run_scene_cell, "grasp-and-lift": run_scene_cell, "empty": run_empty_cell,
             "stability": run_stability_cell, "tradeoff": run_tradeoff_cell}


def run_cell(cell):
    """Runs a cell in this process and returns its row: the key columns, then the metrics; a cell that raises is
    a row with status 'failed' and the engine's message (its first line) instead of metrics."""
    row = {"key": cell["key"], "scene_name": cell.get("scene_name", ""), "scene_hash": cell.get("scene_hash", ""),
           "setting": cell.get("setting", ""), "overrides": cell.get("overrides", "{}"), "protocol": cell["protocol"],
           "engine_version": _haustra.__version__, "status": "ok", "error": ""}
    try:
        if cell.get("import_failed"):
            raise RuntimeError(cell["import_failed"])
        row.update(cell.get("import_report", {}))
        started = time.perf_counter()
        row.update(PROTOCOLS[cell["protocol"]](cell))
        row["cell_s"] = time.perf_counter() - started  # a grid row's cost (the projection in docs/studies.md)
    except Exception as e:  # noqa: BLE001 - every failure is a row: the study goes on
        row["status"], row["error"] = "failed", first_line(e)
    return row


def _stability_cells(doc, path):
    """The stability map (`make stability-doc`): the main sweep, then the N = 20,000 corner, one task per cell."""
    from .spec import cell_key
    cells = []
    for large_n in (False, True):
        for params in _haustra._studies.stability_cells(large_n):
            text = json.dumps(params, sort_keys=True)
            cells.append({"key": cell_key("stability", {}, "stability", {"params": params, "large_n": large_n}),
                          "scene_name": "stability-rod", "setting": f"N={params['nodes']} E={params['youngs_modulus']:g} "
                          f"dt={params['dt']:g} {params['load']} {params['law']}", "protocol": "stability",
                          "params": text, "large_n": large_n})
    return cells


def _tradeoff_cells(doc, path):
    """The speed/accuracy study (`make study`): one task per knob."""
    from .spec import cell_key
    return [{"key": cell_key("tradeoff", {}, "tradeoff", {"knob": name}), "scene_name": "tradeoff", "setting": name,
             "protocol": "tradeoff", "knob": name} for name in _haustra._studies.tradeoff_knob_names()]


def _empty_cells(doc, path):
    """`cells` empty cells: what the scheduler costs per cell."""
    from .spec import cell_key
    count = doc.get("study", {}).get("cells", 100)
    return [{"key": cell_key("empty", {}, "empty", {"index": i}), "scene_name": "empty", "setting": str(i),
             "protocol": "empty"} for i in range(count)]


STUDY_KINDS = {"grid": None, "stability": _stability_cells, "tradeoff": _tradeoff_cells, "empty": _empty_cells}
