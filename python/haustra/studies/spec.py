"""A study file (TOML) read into cells: the grid of scenes or surfaces × settings × protocols, each cell keyed."""
import hashlib
import itertools
import json
import pathlib
import tomllib

from .._haustra import __version__ as ENGINE_VERSION
from .cells import GRID_PROTOCOLS, STUDY_KINDS


class StudyError(ValueError):
    """A study file that cannot be run: the message names the file, the field and what was expected."""


def file_hash(path):
    """The first 16 hex digits of the file's SHA-256: what a cell's key says about its input."""
    return hashlib.sha256(pathlib.Path(path).read_bytes()).hexdigest()[:16]


def cell_key(input_hash, overrides, protocol, extra=None):
    """The cell's key: input file hash + overrides + protocol (+ what else fixes the run) + engine version.
    Written into every row; a rerun skips the keys already in the table (resume)."""
    text = json.dumps({"input": input_hash, "overrides": overrides, "protocol": protocol, "extra": extra or {},
                       "engine": ENGINE_VERSION}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:20]


class Study:
    """What a study file describes: name, kind, its cells (dicts, each with a unique 'key') and options."""

    def __init__(self, name, kind, cells, source=None, reference=None, imports=None, threads=1):
        self.name, self.kind, self.cells, self.source = name, kind, cells, source
        self.threads = threads  # a world's threads in each cell, and in each surface's import
        self.reference = reference  # the setting tip errors are measured against (grid studies)
        self.imports = imports or {}  # surface name -> its import job (surface studies)
        keys = [c["key"] for c in cells]
        if len(set(keys)) != len(keys):
            raise StudyError(f"{source}: two cells have the same key (the same scene, overrides and protocol twice)")


def _require(table, field, kind, where):
    if field not in table:
        raise StudyError(f"{where}: missing field '{field}' (expected {kind})")
    return table[field]


def _settings(doc, where):
    """Named settings ([[setting]] name + overrides) followed by every combination of [sweep]."""
    settings = []
    for i, s in enumerate(doc.get("setting", [])):
        name = _require(s, "name", "a string naming the setting", f"{where}: setting[{i}]")
        overrides = s.get("overrides", {})
        if not isinstance(overrides, dict):
            raise StudyError(f"{where}: setting[{i}].overrides: expected a table of scene fields, got {overrides!r}")
        settings.append((str(name), dict(overrides)))
    sweep = doc.get("sweep", {})
    for field, values in sweep.items():
        if not isinstance(values, list) or not values:
            raise StudyError(f"{where}: sweep.{field}: expected a non-empty list of values, got {values!r}")
    fields = list(sweep)
    for combination in itertools.product(*(sweep[f] for f in fields)) if fields else []:
        overrides = dict(zip(fields, combination))
        settings.append((",".join(f"{f}={v}" for f, v in overrides.items()), overrides))
    if not settings:
        settings.append(("default", {}))
    names = [n for n, _ in settings]
    if len(set(names)) != len(names):
        raise StudyError(f"{where}: two settings are both named '{next(n for n in names if names.count(n) > 1)}'")
    return settings


def load_study(path):
    """Reads STUDY.toml; relative paths in it are relative to the file."""
    path = pathlib.Path(path)
    try:
        with open(path, "rb") as f:
            doc = tomllib.load(f)
    except OSError as e:
        raise StudyError(f"{path}: cannot read the study file ({e.strerror})") from e
    except tomllib.TOMLDecodeError as e:
        raise StudyError(f"{path}: not TOML: {e}") from e
    head = doc.get("study", {})
    name = head.get("name", path.stem)
    kind = head.get("kind", "grid")
    if kind not in STUDY_KINDS:
        raise StudyError(f"{path}: study.kind = '{kind}': expected one of {', '.join(sorted(STUDY_KINDS))}")
    if kind != "grid":
        return Study(name, kind, STUDY_KINDS[kind](doc, path), source=path)
    return grid_study(doc, path, name)


def grid_study(doc, path, name):
    """scenes (files) or surfaces (a folder of .obj, each imported first) × settings × protocols."""
    head, grid = doc.get("study", {}), doc.get("grid", {})
    where = str(path)
    base = path.parent
    threads = head.get("threads", 1)
    frames = head.get("frames")
    if not isinstance(threads, int) or threads < 1:
        raise StudyError(f"{where}: study.threads = {threads!r}: expected an integer ≥ 1 (threads per world, fixed)")
    if frames is not None and (not isinstance(frames, int) or frames < 0):
        raise StudyError(f"{where}: study.frames = {frames!r}: expected an integer ≥ 0")
    protocols = grid.get("protocols", ["scripted"])
    for p in protocols:
        if p not in GRID_PROTOCOLS:
            raise StudyError(f"{where}: grid.protocols: '{p}' is not a protocol (expected one of "
                             f"{', '.join(sorted(GRID_PROTOCOLS))})")
    inputs, imports = [], {}
    for s in grid.get("scenes", []):
        scene = (base / s).resolve()
        if not scene.is_file():
            raise StudyError(f"{where}: grid.scenes: '{s}': no such file ({scene})")
        inputs.append((scene.stem, str(scene), file_hash(scene), None))
    if "surfaces" in grid:
        folder = (base / grid["surfaces"]).resolve()
        if not folder.is_dir():
            raise StudyError(f"{where}: grid.surfaces: '{grid['surfaces']}': not a folder ({folder})")
        surfaces = sorted(folder.glob("*.obj"))
        if "limit" in grid:
            surfaces = surfaces[:grid["limit"]]
        for surface in surfaces:
            imports[surface.stem] = {"surface": str(surface)}
            inputs.append((surface.stem, None, file_hash(surface), surface.stem))
    if not inputs:
        raise StudyError(f"{where}: grid: no input (expected 'scenes', a list of scene files, or 'surfaces', a folder)")
    settings = _settings(doc, where)
    reference = head.get("reference")
    if reference is not None and reference not in [n for n, _ in settings]:
        raise StudyError(f"{where}: study.reference = '{reference}': no setting has that name")
    cells = []
    for (scene_name, scene, digest, surface), (setting, overrides), protocol in itertools.product(
            inputs, settings, protocols):
        fixed = dict(overrides)
        fixed["world.threads"] = threads  # threads per world fixed per cell: the same bits anywhere
        extra = {"frames": frames, "imported": surface is not None}
        cells.append({"key": cell_key(digest, fixed, protocol, extra), "scene_name": scene_name, "scene": scene,
                      "scene_hash": digest, "surface": surface, "setting": setting,
                      "overrides": json.dumps(fixed, sort_keys=True), "protocol": protocol, "frames": frames})
    return Study(name, "grid", cells, source=path, reference=reference, imports=imports, threads=threads)
