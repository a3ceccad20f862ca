"""What a finished study writes beside its results.csv: a summary, plots, and the project studies' own tables."""
import json
import math
import pathlib

from .. import _haustra
from .cells import TIMING_COLUMNS


def number(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


def deterministic(row):
    """The row without its wall-clock columns: what must be the same bits wherever the cell ran."""
    return {k: v for k, v in row.items() if k not in TIMING_COLUMNS}


def tip_errors(rows, reference):
    """m: each ok row's tip against the reference setting's tip of the same scene and protocol."""
    tips = {(r["scene_name"], r["protocol"]): r for r in rows if r["setting"] == reference and r["status"] == "ok"}
    errors = {}
    for r in rows:
        ref = tips.get((r["scene_name"], r["protocol"]))
        if ref is not None and r["status"] == "ok":
            errors[r["key"]] = math.dist([number(r[f"tip_{a}"]) for a in "xyz"],
                                         [number(ref[f"tip_{a}"]) for a in "xyz"])
    return errors


PLOTTED = [("tip_error_m", "tip error against the reference (m)"), ("force_max_N", "largest instrument force (N)"),
           ("penetration_max_m", "deepest penetration (m)"), ("frame_ms_median", "frame, median (ms)")]
# An imported organ (the organ protocol): what the grasp did and how far the organ drifted, not a tip.
ORGAN_PLOTTED = [("grasp_moved_mm", "grasped node moved (mm)"), ("force_max_N", "largest instrument force (N)"),
                 ("drift_rest_max_mm", "drift left alone, farthest node (mm)"),
                 ("drift_after_max_mm", "from rest after release, farthest node (mm)")]


def plot_grid(rows, errors, path):
    """Metric against setting, one line per scene, one panel per metric (and protocol)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    settings = list(dict.fromkeys(r["setting"] for r in rows))
    protocols = list(dict.fromkeys(r["protocol"] for r in rows))
    organ = any(r["protocol"] == "organ" for r in rows)
    metrics = ORGAN_PLOTTED if organ else [(m, label) for m, label in PLOTTED if m != "tip_error_m" or errors]
    fig, axes = plt.subplots(len(protocols), len(metrics), figsize=(4.2 * len(metrics), 3.4 * len(protocols)),
                             squeeze=False)
    for i, protocol in enumerate(protocols):
        for j, (metric, label) in enumerate(metrics):
            ax = axes[i][j]
            for scene in dict.fromkeys(r["scene_name"] for r in rows):
                mine = {r["setting"]: r for r in rows if r["scene_name"] == scene and r["protocol"] == protocol}
                ys = [errors.get(mine[s]["key"], math.nan) if metric == "tip_error_m" else number(mine[s][metric])
                      if s in mine and mine[s]["status"] == "ok" else math.nan for s in settings]
                ax.plot(range(len(settings)), ys, marker="o", linewidth=1, markersize=3, label=scene)
            ax.set_xticks(range(len(settings)), settings, rotation=30, ha="right", fontsize=7)
            ax.set_title(f"{protocol}: {label}", fontsize=8)
    if len({r["scene_name"] for r in rows}) <= 12:
        axes[0][0].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def import_table(rows):
    """One line per imported surface: what the import found and its run of the organ protocol at the defaults
    (the row `make anatomy` writes for it)."""
    lines = ["Each surface as imported (`haustra anatomy` on it alone: the same import, organ protocol and row as "
             "`make anatomy`; its frame time is on the study's threads per world):", "",
             "| surface | organ | length mm | nodes | beads | import s | at rest: median / farthest mm | force N | "
             "pulled mm | after release: median / farthest mm | torn | frame ms | outcome | reused |",
             "|" + "---|" * 14]
    seen = set()
    for r in rows:
        if r["scene_name"] in seen:
            continue
        seen.add(r["scene_name"])
        if not r.get("import_nodes"):
            lines.append(f"| {r['scene_name']} | {r['error']} |" + " |" * 12)
            continue
        lines.append("| " + " | ".join([r["scene_name"]] + [r[c] for c in (
            "import_organ", "import_length_mm", "import_nodes", "import_beads", "import_s")] + [
            f"{r['protocol_rest_median_mm']} / {r['protocol_rest_max_mm']}", r["protocol_force_N"],
            r["protocol_pulled_mm"], f"{r['protocol_after_median_mm']} / {r['protocol_after_max_mm']}",
            r["protocol_torn"], r["protocol_frame_ms"], r["protocol_outcome"], r.get("import_reused", "")]) + " |")
    return lines


def cell_lines(rows, errors):
    """The summary's table: one line per cell; the tip error column only when the study names a reference."""
    tip_column = bool(errors)
    head = ["scene", "setting", "protocol", "status"] + (["tip error mm"] if tip_column else []) + [
        "grasped node lift mm", "grasp moved mm", "force max N", "drift at rest mm (max)", "penetration mm",
        "energy change J", "events (recovered/unstable)", "frame ms (p99)", "cell s"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [r["scene_name"], r["setting"], r["protocol"]]
        if r["status"] != "ok":
            lines.append("| " + " | ".join(cells + [f"failed: {r['error']}"]) + " |" + " |" * (len(head) - 4))
            continue
        tip = [f"{1e3 * errors[r['key']]:.3f}" if r["key"] in errors else ""] if tip_column else []
        cells += ["ok"] + tip + [f"{1e3 * number(r['lift_m']):.2f}", f"{number(r.get('grasp_moved_mm')):.2f}",
                                 f"{number(r['force_max_N']):.3g}", f"{number(r.get('drift_rest_max_mm')):.3f}",
                                 f"{1e3 * number(r['penetration_max_m']):.3f}", f"{number(r['energy_change_J']):.3g}",
                                 f"{r['recovered']}/{r['unstable']}",
                                 f"{number(r['frame_ms_median']):.2f} ({number(r['frame_ms_p99']):.2f})",
                                 f"{number(r.get('cell_s')):.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def grid_summary(study, rows, out):
    errors = tip_errors(rows, study.reference) if study.reference else {}
    ok = [r for r in rows if r["status"] == "ok"]
    lines = [f"# Study: {study.name}", "", f"{len(rows)} cells: {len(ok)} ran, {len(rows) - len(ok)} failed. "
             f"Engine {rows[0]['engine_version'] if rows else '?'}; every row keyed by scene file hash, overrides, "
             "protocol and engine version (results.csv). Frame and cell times are wall times on the machine "
             "that ran the cell; every other number is the same bits wherever it ran.", ""]
    lines += cell_lines(rows, errors)
    if study.imports:
        lines += [""] + import_table(rows)
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    plot_grid(rows, errors, out / "plots.png")
    return ["summary.md", "plots.png"]


def typed_stability(row):
    cell = {k: row[k] for k in ("load", "law", "outcome", "detail", "fast_outcome", "fast_detail")}
    cell.update(youngs_modulus=float(row["youngs_modulus"]), dt=float(row["dt"]), nodes=int(row["nodes"]),
                frames=int(row["frames"]), finite=row["finite"] == "true", names_cause=row["names_cause"] == "true")
    return cell


def stability_tables(rows, out):
    """stability.md (as `haustra stability --markdown`) and stability-map.csv (as its --csv) from the rows."""
    cells = [typed_stability(r) for r in rows]
    (out / "stability.md").write_text(_haustra._studies.stability_markdown(cells))
    lines = ["nodes,youngs_modulus,dt,load,law,outcome,fast_outcome"]
    lines += [f"{c['nodes']},{c['youngs_modulus']:g},{c['dt']:g},{c['load']},{c['law']},{c['outcome']},"
              f"{c['fast_outcome']}" for c in cells]
    (out / "stability-map.csv").write_text("\n".join(lines) + "\n")
    return ["stability.md", "stability-map.csv"]


def tradeoff_tables(rows, out, seconds):
    """tradeoff.md and tradeoff.csv (as `haustra study --markdown --csv`) from the knobs' rows."""
    knobs = [json.loads(r["knob_measured"]) for r in rows]
    (out / "tradeoff.md").write_text(_haustra._studies.tradeoff_markdown(knobs, seconds))
    (out / "tradeoff.csv").write_text(_haustra._studies.tradeoff_csv(knobs))
    return ["tradeoff.md", "tradeoff.csv"]


def write_report(study, result, out):
    """The files a finished study adds; none while cells are missing or (project studies) failed."""
    out = pathlib.Path(out)
    rows = result["rows"]
    if len(rows) != len(study.cells):
        return []
    if study.kind == "grid":
        return grid_summary(study, rows, out)
    if any(r["status"] != "ok" for r in rows):
        return []
    if study.kind == "stability":
        return stability_tables(rows, out)
    if study.kind == "tradeoff":
        return tradeoff_tables(rows, out, result["seconds"])
    return []
