"""World-frames per second from Python (decision 0103): a Python loop stepping each world a frame in
turn, against haustra.Batch on 1 and 2 threads, for N = 1 ... 1,000 worlds of the rollout rod that
bench/bench_batch.cpp steps in C++. Writes Google Benchmark's JSON layout (`make bench`).

    PYTHONPATH=build/release/python /usr/bin/python3 python/tools/bench_batch.py --out build/release/bench_batch_python.json
"""
import argparse
import json
import platform
import time

import haustra

FRAMES = 10  # per world and repetition, as the C++ benchmark
SCENE = {"scene": {"name": "rollout"}, "world": {"dt": 0.01, "threads": 1, "gravity": [0.0, 0.0, -9.81]},
         "segment": [{"name": "rod", "nodes": 21, "youngs_modulus": 1e6, "rest": {"length": 1.0}}]}


def rate(run, worlds, min_seconds):
    """World-frames per second of run(), repeated for at least min_seconds."""
    run()  # warm
    repetitions, started = 0, time.perf_counter()
    while True:
        run()
        repetitions += 1
        elapsed = time.perf_counter() - started
        if elapsed >= min_seconds:
            return repetitions * worlds * FRAMES / elapsed, elapsed / repetitions


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True)
    parser.add_argument("--worlds", type=int, nargs="+", default=[1, 10, 100, 1000])
    parser.add_argument("--min-seconds", type=float, default=0.5)
    args = parser.parse_args()
    rows = []
    for count in args.worlds:
        worlds = [haustra.World(SCENE) for _ in range(count)]

        def loop():
            for _ in range(FRAMES):
                for w in worlds:
                    w.step(1)
        per_second, seconds = rate(loop, count, args.min_seconds)
        rows.append({"name": f"PythonLoop/worlds:{count}", "worlds": count, "threads": 1,
                     "world_frames_per_second": per_second, "real_time": seconds * 1e3, "time_unit": "ms"})
        for threads in (1, 2):
            batch = haustra.Batch(worlds, threads=threads)
            per_second, seconds = rate(lambda: batch.step(FRAMES), count, args.min_seconds)
            rows.append({"name": f"PythonBatch/worlds:{count}/threads:{threads}", "worlds": count, "threads": threads,
                         "world_frames_per_second": per_second, "real_time": seconds * 1e3, "time_unit": "ms"})
        for r in rows[-3:]:
            print(f"{r['name']:<36} {r['world_frames_per_second']:>12,.0f} world-frames/s")
    context = {"date": time.strftime("%Y-%m-%d %H:%M:%S"), "host_name": platform.node(),
               "executable": "python/tools/bench_batch.py", "haustra_version": haustra.__version__,
               "frames_per_repetition": FRAMES}
    with open(args.out, "w") as f:
        json.dump({"context": context, "benchmarks": rows}, f, indent=1)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
