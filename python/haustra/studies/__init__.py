"""haustra.studies: grids of scenes or surfaces × settings × protocols, each cell a Dask task returning a row.

    python3 -m haustra.studies run STUDY.toml [--scheduler ADDRESS | --workers N | --serial] [--out DIR]

    from haustra import studies
    study = studies.load_study("python/studies/cantilever-sweep.toml")
    result = studies.run_study(study, "out/sweep", workers=2)   # or serial=True, or scheduler="tcp://..."

A cell builds its world with its threads fixed (study.threads, default 1), so its row is the same
bits on any worker; every row carries its key (scene file hash, overrides, protocol, engine
version); a cell that raises is a row with the engine's message; a rerun skips the keys already
written. docs/studies.md has the file format, the project's own studies and the cluster recipe.
"""
from .cells import TIMING_COLUMNS, run_cell  # noqa: F401
from .report import deterministic, write_report  # noqa: F401
from .runner import columns_for, read_rows, run_study  # noqa: F401
from .spec import Study, StudyError, cell_key, load_study  # noqa: F401

__all__ = ["Study", "StudyError", "load_study", "run_study", "run_cell", "read_rows", "write_report", "cell_key",
           "columns_for", "deterministic", "TIMING_COLUMNS"]
