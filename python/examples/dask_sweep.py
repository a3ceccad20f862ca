#!/usr/bin/env python3
"""A parameter sweep on Dask: Young's modulus × time step of the grasp-and-pull scene, one task per cell
on a local cluster of worker processes (or any scheduler: --scheduler tcp://host:8786), through
haustra.studies (decision 0070): keyed rows in results.csv, a summary and plots; run it again and only
the missing cells run.

    PYTHONPATH=build/release/python python3 python/examples/dask_sweep.py --out out/python/sweep
"""
import argparse
import pathlib

from haustra import studies

ROOT = pathlib.Path(__file__).resolve().parents[2]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/python/sweep")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--scheduler", help="a running Dask scheduler instead of a local cluster")
    parser.add_argument("--frames", type=int, default=60)
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    study_file = out / "sweep.toml"
    study_file.write_text(f"""
[study]
name = "youngs-modulus-by-dt"
frames = {args.frames}
[grid]
scenes = ["{ROOT / 'scenes' / 'grasp-pull.toml'}"]
protocols = ["grasp-and-lift"]
[sweep]
"segment.youngs_modulus" = [11066.0, 33200.0, 99600.0]
"world.dt" = [0.008333333333333333, 0.016666666666666666]
""")
    study = studies.load_study(study_file)
    result = studies.run_study(study, out, workers=args.workers, scheduler=args.scheduler, show_progress=False)
    written = studies.write_report(study, result, out)
    for row in result["rows"]:
        print(f"{row['setting']:<60} force {float(row['force_max_N']):6.2f} N  lift {1e3 * float(row['lift_m']):5.2f} mm")
    print(f"{result['ran']} cells run, {result['skipped']} already there, {result['failed']} failed; "
          f"wrote {', '.join(str(out / w) for w in written)}")


if __name__ == "__main__":
    main()
