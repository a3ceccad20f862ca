#!/usr/bin/env python3
"""The abdomen's tables in docs/performance.md from one BM_Abdomen run's JSON.

Usage: haustra_bench_anatomy --benchmark_filter=BM_Abdomen --benchmark_out=abdomen.json \
           --benchmark_out_format=json
       scripts/abdomen-table.py abdomen.json
Prints the tail table (median, p99, p99.9, max) and the stage table (each stage's own time, µs a
frame on average), one column per run, in the order the benchmark ran them. With
--benchmark_repetitions, each number is the median over the repetitions.
"""
import json
import re
import statistics
import sys

SOLVER = {"0": "Newton, 2 iterations", "2": "fast mode"}
READER = {"0": "none", "1": "a render thread taking the rings every 1/60 s (the GPU path)"}
SLEEP = {"0": "off", "1": "rods", "2": "rods and ranges"}
SHORT_SLEEP = {"0": "", "1": ", rods asleep", "2": ", ranges asleep"}
# The frame's pipeline order (engine/src/step/frame.cpp); stages not listed follow.
PIPELINE = ["instruments", "snapshot", "collide", "contacts", "proxy", "loads", "free_base", "backward_sweep",
            "condense", "solve", "line_search", "constraints", "forward_sweep", "filter", "contraction", "guard",
            "report", "cage", "skin", "normals"]


def main(path):
    repeats = {}
    for b in json.load(open(path))["benchmarks"]:
        m = re.search(r"solver:(\d)/reader:(\d)/sleep:(\d)", b["name"])
        if m is None or b.get("run_type") == "aggregate":
            continue
        repeats.setdefault(m.groups(), []).append(b)
    runs = []
    for key, bs in repeats.items():
        numbers = {k for b in bs for k, v in b.items() if isinstance(v, (int, float))}
        runs.append((key, {k: statistics.median(b[k] for b in bs if k in b) for k in numbers}))
    print("| solver | reader | sleeping | median ms | p99 ms | p99.9 ms | max ms | nodes asleep at the end |")
    print("|---|---|---|---|---|---|---|---|")
    for (solver, reader, sleep), b in runs:
        print(f"| {SOLVER[solver]} | {READER[reader]} | {SLEEP[sleep]} | {b['median ms']:.3f} | {b['p99 ms']:.3f} "
              f"| {b['p99.9 ms']:.3f} | {b['max ms']:.2f} | {int(b['nodes asleep at the end'])} |")
    print()
    names = [f"{'fast' if s == '2' else 'Newton'}{', GPU reader' if r == '1' else ''}{SHORT_SLEEP[z]}"
             for (s, r, z), _ in runs]
    print("| stage | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(runs))
    stages = []
    for _, b in runs:
        for k in b:
            if k.startswith("stage ") and k.endswith(" us") and k not in stages:
                stages.append(k)
    stages.sort(key=lambda k: PIPELINE.index(k[6:-3]) if k[6:-3] in PIPELINE else len(PIPELINE))
    for k in stages:
        print(f"| {k[6:-3]} | " + " | ".join(f"{b.get(k, 0.0):.1f}" for _, b in runs) + " |")


if __name__ == "__main__":
    main(sys.argv[1])
