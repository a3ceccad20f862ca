#!/usr/bin/env python3
"""The project's own studies on Dask against their commands: the stability map (`haustra stability`, the table
of `make stability-doc`) and the speed/accuracy study (`haustra study`, `make study`), each run both ways now,
their tables compared — the whole stability table and CSV byte for byte, the trade-off CSV's deterministic
columns (knob, setting, error, error name, cost name, default; cost and Pareto flag are timings); and the
cohort's import rows (from `make studies-doc`'s out/studies/cohort) against docs/anatomy.md (`make anatomy`),
every column but the timings.

    PYTHONPATH=build/release/python HAUSTRA_BIN=build/release/bin/haustra \
      /usr/bin/python3 scripts/studies-compare.py [--workers 2] [--only stability|tradeoff|anatomy]
Exit 0 when every compared table matches.
"""
import argparse
import csv
import io
import os
import pathlib
import subprocess
import sys
import tempfile

from haustra import studies

ROOT = pathlib.Path(__file__).resolve().parents[1]
DETERMINISTIC_TRADEOFF = ["knob", "setting", "error", "error_name", "cost_name", "default"]


def dask_study(name, out, workers):
    study = studies.load_study(ROOT / "python" / "studies" / f"{name}.toml")
    result = studies.run_study(study, out, workers=workers)
    written = studies.write_report(study, result, out)
    if result["failed"] or not written:
        sys.exit(f"{name}: {result['failed']} cells failed on Dask: {out / 'results.csv'}")
    return result


def command(args, cwd):
    return subprocess.run([os.environ.get("HAUSTRA_BIN", str(ROOT / "build/release/bin/haustra"))] + args,
                          cwd=cwd, capture_output=True, text=True)


def compare_stability(work, workers):
    dask_study("stability", work / "dask-stability", workers)
    done = command(["stability", "--markdown", "--csv", str(work / "cli-stability.csv")], work)
    same_md = done.stdout == (work / "dask-stability" / "stability.md").read_text()
    same_csv = (work / "cli-stability.csv").read_text() == (work / "dask-stability" / "stability-map.csv").read_text()
    print(f"stability: markdown {'identical' if same_md else 'DIFFERS'}, CSV {'identical' if same_csv else 'DIFFERS'}"
          f" (`haustra stability` exit {done.returncode})")
    return same_md and same_csv


def deterministic_columns(text):
    return [[row[c] for c in DETERMINISTIC_TRADEOFF] for row in csv.DictReader(io.StringIO(text))]


def compare_tradeoff(work, workers):
    dask_study("tradeoff", work / "dask-tradeoff", workers)
    command(["study", "--csv", str(work / "cli-tradeoff.csv")], work)
    mine = deterministic_columns((work / "dask-tradeoff" / "tradeoff.csv").read_text())
    theirs = deterministic_columns((work / "cli-tradeoff.csv").read_text())
    differing = [(a, b) for a, b in zip(mine, theirs) if a != b]
    same = len(mine) == len(theirs) and not differing
    print(f"tradeoff: {len(mine)} rows, deterministic columns {'identical' if same else 'DIFFER'}"
          + "".join(f"\n  dask {a}\n  cli  {b}" for a, b in differing))
    return same


# The table's deterministic columns (docs/anatomy.md; its times and frame counts over the budget are this
# machine's) and the study's import columns that carry them.
ANATOMY_COLUMNS = [("organ", "import_organ"), ("length mm", "import_length_mm"), ("nodes", "import_nodes"),
                   ("beads", "import_beads"), ("force N", "protocol_force_N"), ("pulled mm", "protocol_pulled_mm"),
                   ("torn", "protocol_torn"), ("outcome", "protocol_outcome")]


def compare_anatomy(results):
    """The cohort study's import columns against docs/anatomy.md, surface by surface."""
    from haustra.studies.cells import parse_anatomy_row
    if not results.exists():
        print(f"anatomy: no {results} (run `make studies-doc` first): not compared")
        return True
    table = (ROOT / "docs" / "anatomy.md").read_text()
    first = {}
    for row in studies.read_rows(results):
        first.setdefault(row["scene_name"], row)
    differing = [(name, theirs, mine, parse_anatomy_row(table, name)[theirs], row[mine])
                 for name, row in first.items() for theirs, mine in ANATOMY_COLUMNS
                 if parse_anatomy_row(table, name)[theirs] != row[mine]]
    print(f"anatomy: {len(first)} surfaces × {len(ANATOMY_COLUMNS)} columns against docs/anatomy.md: "
          f"{'identical' if not differing else f'{len(differing)} DIFFER'}"
          + "".join(f"\n  {d[0]} {d[1]}: anatomy.md {d[3]!r}, study {d[4]!r}" for d in differing))
    return not differing


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--only", choices=["stability", "tradeoff", "anatomy"])
    parser.add_argument("--cohort-results", type=pathlib.Path, default=ROOT / "out" / "studies" / "cohort" / "results.csv",
                        help="the cohort study's table to compare with docs/anatomy.md")
    args = parser.parse_args()
    work = pathlib.Path(tempfile.mkdtemp(prefix="haustra-studies-compare-"))
    ok = True
    if args.only in (None, "stability"):
        ok = compare_stability(work, args.workers) and ok
    if args.only in (None, "tradeoff"):
        ok = compare_tradeoff(work, args.workers) and ok
    if args.only in (None, "anatomy"):
        ok = compare_anatomy(args.cohort_results) and ok
    print(f"work files: {work}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
