#!/usr/bin/python3
"""Plots for docs/figures (Debian's python3-matplotlib; run with /usr/bin/python3).

  plots.py fig4 RUN_DIR OUT.png   the paper's Fig. 4 from a run of scenes/sag.toml: both rods'
                                  final centrelines with the quartic beam curve and the catenary
  plots.py fig2 OUT.png           the paper's Fig. 2: EXP2 against Hooke, stress against strain
  plots.py run RUN_DIR PREFIX     from any run's frames.csv: penetration, instrument force, energy
                                  and per-stage time against frame (PREFIX-penetration.png, ...)
  plots.py soak SOAK.csv PREFIX   from haustra_soak's samples: memory (PREFIX-memory.png) and
                                  energy with its allowed band (PREFIX-energy.png) against frame
  plots.py stability CELLS.csv OUT.png
                                  the stability map (haustra stability --csv): one heat map per
                                  load and law, rows N × E, columns Δt, ok / robust / error
  plots.py tradeoff ROWS.csv OUT.png
                                  the speed/accuracy study (haustra study --csv): per knob, error
                                  against cost, the Pareto front joined, the default ringed
"""
import csv
import json
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

G = 9.81


def finish(fig, ax, xlabel, ylabel, out, title=None, legend_size=8, dpi=120):
    """Labels, legend, grid, tight layout, saved."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    ax.legend(fontsize=legend_size)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=dpi)


def catenary(length, span):
    """y(x) of the catenary of a given length hanging between two points at equal height."""
    lo, hi = 1e-6, 1e6  # 2a sinh(span / 2a) = length, solved for a by bisection on a log scale
    for _ in range(200):
        a = math.sqrt(lo * hi)
        if 2 * a * math.sinh(span / (2 * a)) > length:
            lo = a
        else:
            hi = a
    a = math.sqrt(lo * hi)
    return lambda x: a * math.cosh((x - span / 2) / a) - a * math.cosh(span / (2 * a))


def fig4(run, out):
    """Both rods' shapes, each over its own midspan sag, against the two analytic shapes."""
    s = json.load(open(f"{run}/summary.json"))
    fig, ax = plt.subplots(figsize=(8, 4.2))
    for seg, colour in zip(s["segments"], ["tab:blue", "tab:red"]):
        p = seg["final_node_positions_m"]
        xs = [q[0] - p[0][0] for q in p]
        zs = [q[2] - p[0][2] for q in p]
        span = xs[-1]
        sag = -min(zs)
        grid = [span * i / 200 for i in range(201)]
        if seg["name"] == "elastic":
            q = seg["linear_density_kg_per_m"] * G
            b = seg["bending_stiffness_Nm2"]
            ref = [-q * x * x * (span - x) ** 2 / (24 * b) for x in grid]
            label = "clamped beam q x²(L−x)²/24B"
        else:
            length = sum(math.dist(p[i], p[i + 1]) for i in range(len(p) - 1))
            y = catenary(length, span)
            ref = [y(x) for x in grid]
            label = "catenary of the same length and span"
        ref_sag = -min(ref)
        ax.plot(xs, [z / sag for z in zs], "o", ms=3, color=colour,
                label=f"{seg['name']} rod, haustra (sag {1e3 * sag:.3g} mm)")
        ax.plot(grid, [z / ref_sag for z in ref], "-", color=colour, label=f"{label} (sag {1e3 * ref_sag:.3g} mm)")
    finish(fig, ax, "x (m)", "height / midspan sag", out, "Rods held at both ends under gravity (paper Fig. 4)", dpi=130)


def fig2(out):
    # The paper gives no EXP2 parameters; these are illustrative: gamma = 20 kPa initial slope,
    # alpha = 8, and beta chosen so that Hooke's E = 33.2 kPa is the least-squares fit over 0-25 %.
    e_hooke, gamma, alpha = 33.2e3, 20e3, 8.0
    strains = [0.25 * i / 100 for i in range(101)]
    f = [math.exp(alpha * e * e) - 1 for e in strains]
    beta = sum((e_hooke - gamma) * e * fi for e, fi in zip(strains, f)) / sum(fi * fi for fi in f)
    grid = [0.5 * i / 200 for i in range(201)]
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.plot([100 * e for e in grid], [1e-3 * (beta * (math.exp(alpha * e * e) - 1) + gamma * e) for e in grid], "-",
            label=f"EXP2: β(e^(αε²)−1)+γε, α={alpha:g}, β={beta / 1e3:.1f} kPa, γ={gamma / 1e3:g} kPa")
    ax.plot([100 * e for e in grid], [1e-3 * e_hooke * e for e in grid], "--", label="Hooke: E ε, E = 33.2 kPa")
    ax.axvline(25, color="grey", lw=0.8)
    finish(fig, ax, "strain (%)", "stress (kPa)", out, "Linear and EXP2 tissue laws (paper Fig. 2)", legend_size=7, dpi=130)


def run_plots(run, prefix):
    rows = list(csv.DictReader(open(f"{run}/frames.csv")))
    frame = [int(r["frame"]) for r in rows]
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot(frame, [1e3 * float(r["max_environment_depth_m"]) for r in rows], label="deepest into the environment")
    ax.plot(frame, [1e3 * float(r["max_bead_overlap_m"]) for r in rows], label="deepest between beads")
    finish(fig, ax, "frame", "penetration (mm)", f"{prefix}-penetration.png")
    forces = [k for k in rows[0] if k.startswith("instrument") and k.endswith("_fz")]
    if forces:
        fig, ax = plt.subplots(figsize=(7, 3.5))
        for k in forces:
            name = k[: -len("_fz")]
            mag = [math.sqrt(sum(float(r[f"{name}_f{c}"]) ** 2 for c in "xyz")) for r in rows]
            ax.plot(frame, mag, label=f"{name}: |force| (N)")
        finish(fig, ax, "frame", "force on the instrument (N)", f"{prefix}-force.png")
    if "elastic_energy_J" in rows[0]:
        fig, ax = plt.subplots(figsize=(7, 3.5))
        elastic = [float(r["elastic_energy_J"]) for r in rows]
        gravity = [float(r["gravity_energy_J"]) for r in rows]
        ax.plot(frame, [1e3 * e for e in elastic], label="elastic (stored by elastic strain components)")
        ax.plot(frame, [1e3 * (g - gravity[0]) for g in gravity], label="weight's potential, from frame 0")
        ax.plot(frame, [1e3 * (e + g - gravity[0]) for e, g in zip(elastic, gravity)], label="sum")
        finish(fig, ax, "frame", "energy (mJ)", f"{prefix}-energy.png")
    stages = [k[: -len("_us")] for k in rows[0] if k.endswith("_us") and k != "wall_us"]
    stages = [st for st in stages if any(float(r[f"{st}_us"]) > 0 for r in rows)]
    fig, ax = plt.subplots(figsize=(7, 3.8))
    bottom = [0.0] * len(rows)
    for st in stages:
        v = [float(r[f"{st}_us"]) for r in rows]
        ax.fill_between(frame, bottom, [b + x for b, x in zip(bottom, v)], step="mid", label=st)
        bottom = [b + x for b, x in zip(bottom, v)]
    finish(fig, ax, "frame", "time per frame (µs), stacked by stage", f"{prefix}-stages.png", legend_size=6)


def soak_plots(samples, prefix):
    with open(samples) as f:
        rows = list(csv.DictReader(f))
    frame = [int(r["frame"]) for r in rows]
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot(frame, [int(r["resident_kib"]) / 1024 for r in rows], label="resident memory (MiB)")
    ax.plot(frame, [int(r["heap_bytes"]) / 2**20 for r in rows], label="heap in use (MiB)")
    ax.set_ylim(bottom=0)
    finish(fig, ax, "frame", "MiB", f"{prefix}-memory.png")
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot(frame, [float(r["total_J"]) for r in rows], ".", markersize=2, label="energy at the sample (elastic + gravity)")
    ax.plot(frame, [float(r["energy_low_J"]) for r in rows], "k--", linewidth=0.8, label="allowed band")
    ax.plot(frame, [float(r["energy_high_J"]) for r in rows], "k--", linewidth=0.8)
    finish(fig, ax, "frame", "J", f"{prefix}-energy.png")


def tradeoff(rows_csv, out):
    rows = list(csv.DictReader(open(rows_csv)))
    knobs = []
    for r in rows:
        if r["knob"] not in knobs:
            knobs.append(r["knob"])
    cols = 4
    lines = (len(knobs) + cols - 1) // cols
    fig, axes = plt.subplots(lines, cols, figsize=(4.2 * cols, 3.6 * lines), squeeze=False)
    for i, knob in enumerate(knobs):
        ax = axes[i // cols][i % cols]
        mine = [r for r in rows if r["knob"] == knob]
        positive = [float(r["error"]) for r in mine if float(r["error"]) > 0]
        # A zero error (the reference itself, or exact to rounding) is drawn at the floor.
        floor = min(positive) / 10 if positive else 1e-6
        pts = [(float(r["cost_us"]), max(float(r["error"]), floor), r) for r in mine]
        ax.scatter([p[0] for p in pts], [p[1] for p in pts], s=18, color="tab:blue", zorder=3)
        front = sorted((p for p in pts if p[2]["pareto"] == "1"), key=lambda p: p[0])
        if len(front) > 1:
            ax.plot([p[0] for p in front], [p[1] for p in front], "-", color="tab:orange", lw=1.2,
                    label="Pareto front", zorder=2)
        for x, y, r in pts:
            if r["default"] == "1":
                ax.scatter([x], [y], s=90, facecolors="none", edgecolors="tab:red", zorder=4)
            ax.annotate(r["setting"].split(" (")[0].replace("study sweep, ", "").replace("engine kernel, ", "engine, ")[:26], (x, y), fontsize=6, xytext=(3, 2),
                        textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis, (lo, hi) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
            # An axis within a decade gets four plain ticks; a wider one labels only its decades
            # (matplotlib's default labels minor ticks of a narrow log axis, which run into each other).
            if lo > 0 and hi / lo < 10:
                axis.set_major_locator(matplotlib.ticker.MaxNLocator(4))
                axis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
            axis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel(mine[0]["cost_name"], fontsize=8)
        ax.set_ylabel(mine[0]["error_name"], fontsize=8)
        ax.set_title(knob, fontsize=9)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3, which="both")
        if len(front) > 1:
            ax.legend(fontsize=6)
    for j in range(len(knobs), lines * cols):
        axes[j // cols][j % cols].axis("off")
    fig.suptitle("Speed against accuracy (haustra study): error against cost, default ringed in red", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


def stability_map(cells_csv, out):
    from matplotlib.colors import ListedColormap
    rows = list(csv.DictReader(open(cells_csv)))
    loads = ["gravity", "pull", "contact"]
    titles = {"gravity": "gravity", "pull": "gravity + pull to 100 % strain", "contact": "on a stiff floor"}
    laws = ["viscous", "elastic"]
    keys = sorted({(int(r["nodes"]), float(r["youngs_modulus"])) for r in rows})
    dts = sorted({float(r["dt"]) for r in rows})
    code = {"lagged": 0, "robust": 1, "error": 2}
    cmap = ListedColormap(["#4caf50", "#ffc107", "#e53935"])
    fig, axes = plt.subplots(len(laws), len(loads), figsize=(13, 11), sharey=True)
    for i, law in enumerate(laws):
        for j, load in enumerate(loads):
            ax = axes[i][j]
            grid = [[math.nan] * len(dts) for _ in keys]
            for r in rows:
                if r["load"] != load or r["law"] != law:
                    continue
                grid[keys.index((int(r["nodes"]), float(r["youngs_modulus"])))][dts.index(float(r["dt"]))] = code[r["outcome"]]
            ax.imshow(grid, cmap=cmap, vmin=0, vmax=2, aspect="auto", interpolation="nearest")
            ax.set_xticks(range(len(dts)))
            ax.set_xticklabels([f"{d:g}" for d in dts], fontsize=7)
            ax.set_yticks(range(len(keys)))
            ax.set_yticklabels([f"N={n}, E={e:g}" for n, e in keys], fontsize=6)
            ax.set_title(f"{titles[load]}, {law}", fontsize=9)
            if i == len(laws) - 1:
                ax.set_xlabel("Δt (s)", fontsize=8)
    from matplotlib.patches import Patch
    fig.legend(handles=[Patch(color=cmap(k), label=l) for k, l in
                        enumerate(["ok: lagged scheme stable", "robust: recovered by Newton / substeps",
                                   "error: stopped with a named cause"])],
               loc="lower center", ncol=3, fontsize=9)
    fig.suptitle("Stability map: the paper's rectum rod, 1 m, clamped (blank: not run at that N)", fontsize=11)
    fig.tight_layout(rect=(0, 0.04, 1, 0.97))
    fig.savefig(out, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    if len(sys.argv) >= 2 and sys.argv[1] == "fig4":
        fig4(sys.argv[2], sys.argv[3])
    elif len(sys.argv) >= 2 and sys.argv[1] == "fig2":
        fig2(sys.argv[2])
    elif len(sys.argv) >= 2 and sys.argv[1] == "run":
        run_plots(sys.argv[2], sys.argv[3])
    elif len(sys.argv) >= 2 and sys.argv[1] == "stability":
        stability_map(sys.argv[2], sys.argv[3])
    elif len(sys.argv) >= 2 and sys.argv[1] == "tradeoff":
        tradeoff(sys.argv[2], sys.argv[3])
    elif len(sys.argv) >= 2 and sys.argv[1] == "soak":
        soak_plots(sys.argv[2], sys.argv[3])
    else:
        print(__doc__)
        sys.exit(2)
