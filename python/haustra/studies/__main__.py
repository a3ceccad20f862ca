"""`python3 -m haustra.studies run STUDY.toml [--scheduler ADDRESS | --workers N | --serial] [--out DIR]`."""
import argparse
import pathlib
import sys

from .report import write_report
from .runner import run_study
from .spec import StudyError, load_study


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python3 -m haustra.studies",
                                     description="Runs a study (docs/studies.md) on Dask and writes its table.")
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("run", help="run the cells not yet in OUT/results.csv, then write the summary")
    run.add_argument("study", type=pathlib.Path, help="the study file (TOML)")
    where = run.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler: its address (tcp://host:8786) or its scheduler file (JSON)")
    where.add_argument("--workers", type=int, metavar="N", help="a local cluster of N worker processes (default: "
                       "one per core)")
    where.add_argument("--serial", action="store_true", help="in this process, one cell after another, no Dask")
    run.add_argument("--out", type=pathlib.Path, help="results folder (default: out/studies/STUDY-NAME)")
    run.add_argument("--retry-failed", action="store_true", help="run again the cells whose rows say failed")
    run.add_argument("--quiet", action="store_true", help="no progress line")
    args = parser.parse_args(argv)
    if args.workers is not None and args.workers < 1:
        parser.error(f"--workers {args.workers}: expected at least 1")
    try:
        study = load_study(args.study)
    except StudyError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    out = args.out or pathlib.Path("out") / "studies" / study.name
    result = run_study(study, out, serial=args.serial, scheduler=args.scheduler, workers=args.workers,
                       show_progress=not args.quiet, retry_failed=args.retry_failed)
    if result["interrupted"]:
        print(f"{study.name}: stopped ({result['interrupted']}) after {result['ran']} cells run now; the {len(result['rows'])} rows "
              f"written are kept in {out / 'results.csv'}; the same command runs the {len(study.cells) - len(result['rows'])} "
              "cells left", file=sys.stderr)
        return 130
    written = write_report(study, result, out)
    print(f"{study.name}: {len(study.cells)} cells, {result['ran']} run now ({result['skipped']} already written), "
          f"{result['failed']} failed, {result['seconds']:.1f} s; {out / 'results.csv'}"
          + "".join(f", {out / w}" for w in written))
    return 0 if result["failed"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
