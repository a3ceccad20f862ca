"""What one cell does: build its world, run a protocol, measure, return a row (a dict). Runs in any process."""
import hashlib
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
TIMING_COLUMNS = {"frame_ms_median", "frame_ms_p99", "cell_s", "import_s", "import_task_s", "protocol_frame_ms",
                  "protocol_frame_p99_ms", "protocol_late", "knob_measured"}

KEY_COLUMNS = ["key", "scene_name", "scene_hash", "setting", "overrides", "protocol", "engine_version", "status",
               "error"]
GRID_METRICS = ["frames", "finite", "tip_x", "tip_y", "tip_z", "lift_m", "grasp_moved_mm", "force_max_N",
                "force_jump_max_N", "drift_rest_median_mm", "drift_rest_max_mm", "drift_after_median_mm",
                "drift_after_max_mm", "anchors_torn", "penetration_max_m", "bead_overlap_max_m", "energy_change_J",
                "recovered", "unstable", "frame_ms_median", "frame_ms_p99", "cell_s"]
# The import and the organ protocol at the defaults (the row `haustra anatomy` writes for the surface, decision
# 0097: left alone 10 s, grasped and pulled 5 cm sideways in 1 s, held 1 s, released, 3 s): in a surface study's rows.
IMPORT_COLUMNS = ["import_organ", "import_length_mm", "import_nodes", "import_beads", "import_s",
                  "protocol_rest_median_mm", "protocol_rest_max_mm", "protocol_force_N", "protocol_pulled_mm",
                  "protocol_after_median_mm", "protocol_after_max_mm", "protocol_torn", "protocol_skin_worst",
                  "protocol_skin_edges_past_2x", "protocol_frame_ms", "protocol_frame_p99_ms", "protocol_late",
                  "protocol_outcome", "import_task_s", "import_reused"]
LIFT_SECONDS, LIFT_HEIGHT = 1.0, 0.02  # grasp-and-lift: 2 cm in the first second, then held
# The organ protocol's phases (decision 0097, studies' OrganProtocol): left alone, pulled, held, released, s.
# The grasper comes down for half a second after the rest before it closes (protocol.toml's keyframes).
ORGAN_REST, ORGAN_DESCENT, ORGAN_PULL, ORGAN_HOLD, ORGAN_AFTER = 10.0, 0.5, 1.0, 1.0, 3.0


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
    organ = cell["protocol"] == "organ"
    protocol_frames = round((ORGAN_REST + ORGAN_DESCENT + ORGAN_PULL + ORGAN_HOLD + ORGAN_AFTER) / world.dt)
    frames = cell["frames"] if cell["frames"] is not None else protocol_frames if organ else world.scene_frames
    if organ and world.instrument_count == 0:
        raise _haustra.InvalidArgumentError("organ: the scene has no [[instrument]] on the protocol's keyframes (an "
                                            "imported surface's protocol.toml has one)")
    rest_frame = round(ORGAN_REST / world.dt)  # the organ left alone until here
    held_frame = round((ORGAN_REST + ORGAN_DESCENT + ORGAN_PULL + ORGAN_HOLD) / world.dt)  # the end of the hold
    start_positions = np.array(world.node_positions)
    drift_rest = drift_after = None
    moved = float("nan")
    lifting = cell["protocol"] == "grasp-and-lift"
    tip0 = axis = start = None
    if lifting:
        tip0, axis = _grasp_from_above(world)
    frame_seconds, forces, energies = [], [], []
    grasped_node, lift = None, float("nan")
    for frame in range(frames):
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
                grasped_from = np.array(world.node_positions[grasped_node])
        if frame + 1 == rest_frame:  # how far the organ drifted from where it was built, left alone
            drift_rest = np.linalg.norm(world.node_positions - start_positions, axis=1)
        if organ and grasped_node is not None and world.instrument(0)["grasping"] and frame + 1 <= held_frame:
            # as the import's protocol measures it: where the grasp last held the node, by the end of the hold
            moved = float(np.linalg.norm(world.node_positions[grasped_node] - grasped_from))
    if grasped_node is not None:
        lift = float(world.node_positions[grasped_node][2]) - start
        if not organ:  # the grasped node's whole travel
            moved = float(np.linalg.norm(world.node_positions[grasped_node] - grasped_from))
    if organ and frames >= protocol_frames:
        drift_after = np.linalg.norm(world.node_positions - start_positions, axis=1)
    positions = np.array(world.node_positions)
    magnitudes = [float(np.linalg.norm(f)) for f in forces]
    jumps = [float(np.linalg.norm(b - a)) for a, b in zip(forces, forces[1:])]
    contacts = world.contacts
    events = world.events
    tip = positions[-1]
    return {
        "frames": frames, "finite": bool(np.isfinite(positions).all()),
        "tip_x": float(tip[0]), "tip_y": float(tip[1]), "tip_z": float(tip[2]), "lift_m": lift,
        "grasp_moved_mm": 1e3 * moved,
        "drift_rest_median_mm": 1e3 * float(np.median(drift_rest)) if drift_rest is not None else float("nan"),
        "drift_rest_max_mm": 1e3 * float(drift_rest.max()) if drift_rest is not None else float("nan"),
        "drift_after_median_mm": 1e3 * float(np.median(drift_after)) if drift_after is not None else float("nan"),
        "drift_after_max_mm": 1e3 * float(drift_after.max()) if drift_after is not None else float("nan"),
        "anchors_torn": int(np.sum(np.asarray(world.anchors_intact) == 0)),
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


def _split(text, at=" / "):
    """'0.43 / 0.53' -> ('0.43', '0.53'); '1.44 (0)' -> ('1.44', '0')."""
    text = text.strip()
    if at in text:
        a, b = text.split(at, 1)
        return a.strip(), b.strip()
    if "(" in text:
        a, b = text.split("(", 1)
        return a.strip(), b.rstrip(")").strip()
    return text, ""


def import_report(row):
    """A surface study's import columns from the surface's row of `haustra anatomy`'s table."""
    rest, after = _split(row.get("at rest: median / farthest mm", "")), _split(row.get("after release: median / "
                                                                                      "farthest mm", ""))
    skin, frame = _split(row.get("skin: worst edge × (edges past 2×)", "")), _split(row.get("frame ms (p99)", ""))
    return {"import_organ": row.get("organ", ""), "import_length_mm": row.get("length mm", ""),
            "import_nodes": row.get("nodes", ""), "import_beads": row.get("beads", ""),
            "import_s": row.get("import s", ""), "protocol_rest_median_mm": rest[0], "protocol_rest_max_mm": rest[1],
            "protocol_force_N": row.get("force N", ""), "protocol_pulled_mm": row.get("pulled mm", ""),
            "protocol_after_median_mm": after[0], "protocol_after_max_mm": after[1],
            "protocol_torn": row.get("torn", ""), "protocol_skin_worst": skin[0],
            "protocol_skin_edges_past_2x": skin[1], "protocol_frame_ms": frame[0], "protocol_frame_p99_ms": frame[1],
            "protocol_late": row.get("late", ""), "protocol_outcome": row.get("outcome", "")}


IMPORT_RECORD = "study-import.json"  # beside the imported scene: what a resume reuses


def import_surface(surface, out, threads=1):
    """Imports one surface as `make anatomy` does (the same C++ run: `haustra anatomy` on a folder holding
    only it, the organ protocol included), its world on `threads` threads (a study's cells' own: one per
    worker's core, the same bits); returns the import report, the protocol's row and the scene the study's
    cells run: protocol.toml, the imported organ with the protocol's grasper on its keyframes.
    An import already made into `out` of the same surface file (its hash), by the same engine, is reused (a
    resumed study does not import again): its record, study-import.json, says so."""
    surface = pathlib.Path(surface)
    out = pathlib.Path(out)
    folder_out = out / surface.stem
    scene = folder_out / "protocol.toml"
    record = folder_out / IMPORT_RECORD
    digest = hashlib.sha256(surface.read_bytes()).hexdigest()
    if record.is_file() and scene.is_file():
        try:
            kept = json.loads(record.read_text())
        except ValueError:
            kept = {}
        if kept.get("surface_sha256") == digest and kept.get("engine_version") == _haustra.__version__ \
                and kept.get("threads") == threads:
            report = dict(kept["report"], import_reused="true")
            return {"scene": str(scene), "report": report, "seconds": kept["seconds"]}
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="haustra-import-") as folder:
        for part in [surface, surface.with_name(surface.stem + "-centreline.json")]:
            if part.exists():
                os.symlink(part, pathlib.Path(folder) / part.name)
        done = subprocess.run([haustra_command(), "anatomy", folder, "--out", str(out), "--threads", str(threads)],
                              capture_output=True, text=True)
    if done.returncode != 0 and "| surface |" not in done.stdout:
        raise RuntimeError(f"haustra anatomy {surface.name}: exit {done.returncode}: {first_line(done.stderr)}")
    report = import_report(parse_anatomy_row(done.stdout, surface.stem))
    if not scene.is_file():
        raise RuntimeError(f"{surface.name}: not imported ({report['protocol_outcome']}): no {scene}")
    seconds = time.perf_counter() - started
    record.write_text(json.dumps({"surface": str(surface), "surface_sha256": digest, "threads": threads,
                                  "engine_version": _haustra.__version__, "report": report, "seconds": seconds},
                                 indent=1))
    return {"scene": str(scene), "report": dict(report, import_reused="false"), "seconds": seconds}


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


GRID_PROTOCOLS = ["scripted", "grasp-and-lift", "organ"]  # what a grid study's cells may run
PROTOCOLS = {"scripted": run_scene_cell, "grasp-and-lift": run_scene_cell, "organ": run_scene_cell,
             "empty": run_empty_cell,
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
