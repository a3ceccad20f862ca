#!/usr/bin/env python3
"""Writes docs/results.md: every figure the docs quote, from the commands that measure it.

    scripts/results.py BUILD_DIR OUT.md

- the reference cases: `haustra validate --json` (each against an independent reference);
- the figures the tests measure and assert (tests/measured.hpp): the test binary run once with
  HAUSTRA_RESULTS pointing at a scratch file — each figure is checked against its bound as it is
  recorded, so `make test` asserts every one of them;
- the benchmarks of the last `make bench` in BUILD_DIR (bench.json, bench_mesh.json), with their
  own date and machine: speed is measured by benchmarks, not by tests.
"""
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile


def machine():
    model = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} logical CPUs, {platform.system()} {platform.release()}"


def commit():
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True,
                              cwd=os.path.dirname(os.path.abspath(__file__))).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def number(x):
    return f"{x:.3g}"


def validation_table(build):
    done = subprocess.run([os.path.join(build, "bin", "haustra"), "validate", "--json"], capture_output=True,
                          text=True)
    cases = json.loads(done.stdout)
    return validation_rows(cases), all(c["pass"] for c in cases)


def validation_rows(cases):
    rows = ["| case | quantity | reference | value | error | tolerance | |", "|---|---|---|---|---|---|---|"]
    for c in cases:
        error = c.get("relative_error", c.get("absolute_error"))
        kind = "" if "relative_error" in c else " (abs.)"
        rows.append(f"| {c['case']} | {c['quantity']} | {c['reference']:.8g} | {c['value']:.8g} | "
                    f"{number(error)}{kind} | {number(c['tolerance'])} | {'pass' if c['pass'] else '**FAIL**'} |")
    return rows


VALIDATION_HEADING = "## Reference cases (`haustra validate`)"
FIGURES_HEADING = "## Figures the tests measure and assert"


def figure_files():
    """The test files that record a figure (they include measured.hpp): only their cases need to run."""
    tests = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests")
    found = []
    for folder, _, names in os.walk(tests):
        for name in sorted(names):
            if name.endswith(".cpp"):
                with open(os.path.join(folder, name), encoding="utf-8") as f:
                    if '#include "measured.hpp"' in f.read():
                        found.append("*" + name)
    return found


def test_figures(build):
    with tempfile.TemporaryDirectory() as scratch:
        record = os.path.join(scratch, "figures.jsonl")
        env = dict(os.environ, HAUSTRA_RESULTS=record)
        done = subprocess.run([os.path.join(build, "bin", "haustra_tests"), "--source-file=" + ",".join(figure_files())],
                              env=env, capture_output=True, text=True)
        figures = []
        if os.path.exists(record):
            with open(record) as f:
                figures = [json.loads(line) for line in f if line.strip()]
    return figure_rows(figures), done.returncode == 0 and all(g["value"] <= g["bound"] for g in figures)


def figure_rows(figures):
    rows = ["| figure | measured | bound | |", "|---|---|---|---|"]
    for g in figures:
        unit = f" {g['unit']}" if g["unit"] else ""
        ok = g["value"] <= g["bound"]
        name = g["figure"].replace("|", "\\|")  # a pipe would end the table's cell
        rows.append(f"| {name} | {number(g['value'])}{unit} | {number(g['bound'])}{unit} | "
                    f"{'within' if ok else '**above**'} |")
    return rows


def benchmark_rows(build, out):
    rows = []
    for name in ("bench.json", "bench_mesh.json"):
        path = os.path.join(build, name)
        if not os.path.exists(path):
            continue
        with open(path) as f:
            data = json.load(f)
        ctx = data["context"]
        rows.append(f"\n`{name}` — {ctx['date']}, {ctx['num_cpus']} CPUs at {ctx['mhz_per_cpu']} MHz "
                    f"({ctx['library_build_type']} Google Benchmark library)\n")
        rows += ["| benchmark | median or mean, µs | |", "|---|---|---|"]
        seen = {}
        for b in data["benchmarks"]:
            if b.get("run_type") == "aggregate" and b.get("aggregate_name") != "median":
                continue
            base = b.get("run_name", b["name"])
            if base in seen:
                continue
            scale = {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}[b.get("time_unit", "ns")]
            seen[base] = b["real_time"] * scale
            rows.append(f"| {base} | {seen[base]:.4g} | {b.get('aggregate_name', '')} |")
    if not rows:
        rows = kept_benchmarks(out) or [
            "No benchmark results in the build tree: run `make bench` first, then `make results`."]
    return rows


def kept_benchmarks(out):
    """The page's benchmark tables as they are, when the build tree has none newer: each carries its date."""
    if not os.path.exists(out):
        return []
    with open(out, encoding="utf-8") as f:
        lines = f.read().splitlines()
    start = next((i for i, l in enumerate(lines) if l.startswith("`bench")), None)
    if start is None:
        return []
    kept = [l for l in lines[start:] if not l.startswith("<!-- generated:")]
    while kept and not kept[-1].strip():
        kept.pop()
    return [""] + kept


def main():
    build, out = sys.argv[1], sys.argv[2]
    validation, validation_ok = validation_table(build)
    figures, figures_ok = test_figures(build)
    lines = [
        "# Results",
        "",
        f"Generated by `make results` on {datetime.date.today().isoformat()} at commit {commit()}, on "
        f"{machine()}. Do not edit: every number below comes from the command that measures it.",
        "",
        VALIDATION_HEADING,
        "",
        "Each case runs the engine through its public API and compares one number with an independent",
        "reference (closed forms, RK4 shooting and integration: `studies/src/references.cpp`).",
        "",
        *validation,
        "",
        FIGURES_HEADING,
        "",
        "Each is checked against its bound where it is measured (`tests/measured.hpp`), so `make test` fails",
        "when one leaves it; bounds sit within about ten times of what is measured.",
        "",
        *figures,
        "",
        "## Benchmarks (the last `make bench`)",
        "",
        "Speed is measured by Google Benchmark, not by the tests (a shared 2-core machine is noisy); ratios",
        "that matter are taken within one run: docs/performance.md.",
        *benchmark_rows(build, out),
        "",
    ]
    with open(out, "w") as f:
        f.write("\n".join(lines))
    print(f"wrote {out}")
    if not (validation_ok and figures_ok):
        print("results: a reference case failed or a figure left its bound", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
