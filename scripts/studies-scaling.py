#!/usr/bin/env python3
"""Scaling of haustra.studies on this machine, as JSON: the cohort study on 1 and on 2 local workers (the ratio
in one run), and the scheduler's cost per cell (empty cells on a running 2-worker cluster).

    PYTHONPATH=build/release/python HAUSTRA_BIN=build/release/bin/haustra \
      /usr/bin/python3 scripts/studies-scaling.py --out docs/studies-scaling.json [--limit N]
"""
import argparse
import json
import os
import pathlib
import platform
import resource
import shutil
import tempfile
import time

from distributed import Client, LocalCluster

import haustra
from haustra import studies

ROOT = pathlib.Path(__file__).resolve().parents[1]


def timed_run(study, out, address):
    shutil.rmtree(out, ignore_errors=True)
    start = time.perf_counter()
    result = studies.run_study(study, out, scheduler=address, show_progress=False)
    return time.perf_counter() - start, result


def worker_peak_mb(address):
    """MB: the largest peak resident memory of the cluster's worker processes so far."""
    with Client(address) as client:
        peaks = client.run(lambda: resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
    return max(peaks.values()) / 1024.0


def cohort_run(study, out, address):
    seconds, result = timed_run(study, out, address)
    return seconds, result, worker_peak_mb(address)


def task_costs(rows):
    """s: what the tasks themselves took (each surface's import once, each cell's run), from the rows."""
    cells = [float(r["cell_s"]) for r in rows if r["status"] == "ok"]
    imports = list({r["scene_name"]: float(r["import_task_s"]) for r in rows if r.get("import_task_s")}.values())
    return {"cell_seconds_total": sum(cells), "cell_seconds_mean": sum(cells) / len(cells),
            "cell_seconds_max": max(cells), "import_seconds_total": sum(imports),
            "import_seconds_mean": sum(imports) / len(imports), "import_seconds_max": max(imports)}


def on_cluster(workers, run):
    """run(address) on a fresh local cluster of `workers` processes, one thread each (started before timing)."""
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=40) as cluster:
        return run(cluster.scheduler_address)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/studies-scaling.json")
    parser.add_argument("--limit", type=int, help="only the first N surfaces of the cohort")
    parser.add_argument("--empty-cells", type=int, default=400)
    args = parser.parse_args()
    work = pathlib.Path(tempfile.mkdtemp(prefix="haustra-scaling-"))
    cohort = studies.load_study(ROOT / "python" / "studies" / "cohort.toml")
    if args.limit:
        surfaces = sorted(cohort.imports)[:args.limit]
        cohort.cells = [c for c in cohort.cells if c["surface"] in surfaces]
        cohort.imports = {s: cohort.imports[s] for s in surfaces}
    runs = {}
    for workers in (1, 2):
        seconds, result, peak = on_cluster(workers, lambda a, w=workers: cohort_run(cohort, work / f"cohort-{w}", a))
        runs[workers] = {"seconds": seconds, "cells": len(result["rows"]), "failed": result["failed"],
                         "worker_peak_rss_mb": peak,
                         **task_costs(result["rows"])}
    empty = studies.load_study(ROOT / "python" / "studies" / "empty.toml")
    empty.cells = empty.cells[:1]
    many = studies.load_study(ROOT / "python" / "studies" / "empty.toml")
    from haustra.studies.cells import _empty_cells  # the same cells, as many as asked
    many.cells = _empty_cells({"study": {"cells": args.empty_cells}}, None)

    def overhead(address):
        t_one, _ = timed_run(empty, work / "empty-1", address)
        t_many, _ = timed_run(many, work / "empty-many", address)
        return t_one, t_many
    t_one, t_many = on_cluster(2, overhead)
    report = {
        "engine_version": haustra.__version__, "machine": platform.node(), "cores": os.cpu_count(),
        "note": "wall times on a shared virtual machine; ratios within this one run",
        "cohort": {"surfaces": len(cohort.imports), "cells": len(cohort.cells), "one_worker": runs[1],
                   "two_workers": runs[2], "ratio_1_to_2": runs[1]["seconds"] / runs[2]["seconds"]},
        "empty_cells": {"workers": 2, "cells": args.empty_cells, "one_cell_seconds": t_one,
                        "many_cells_seconds": t_many,
                        "seconds_per_cell": (t_many - t_one) / (args.empty_cells - 1)},
    }
    pathlib.Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    pathlib.Path(args.out).write_text(json.dumps(report, indent=2) + "\n")
    print(json.dumps(report, indent=2))
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
