#!/usr/bin/env python3
"""Generated pages kept honest: each carries a stamp of its inputs and its own text; `check` fails on a stale one.

    scripts/pages.py stamp PAGE...                  the Makefile's recipes, after writing PAGE
    scripts/pages.py check [--figures RECORD] [--cli HAUSTRA]   ctest's "generated pages: ..." test (decision 0115)

A stamp is the page's last line: a hash of the inputs that decide its content (its generator, the
scenes and data in the repository it reads) and a hash of the page's own text. `check` recomputes
both for every page below and fails naming the page and the command that regenerates it when
either differs: an input changed since the page was written, or the page was edited by hand.
Hashes ignore whitespace, and C++ comments and the seams of adjacent string literals in the inputs,
so a change of layout alone (clang-format reflows comments and splits long literals) stales nothing. A page that
copies a generated page's tables (docs/skinning.md) must hold every one of their rows.

docs/results.md is checked by content as well: its reference cases are `HAUSTRA validate --json`'s
now (about a second), and the figures the tests of this ctest run measured
(tests/measured.hpp appends them to RECORD) are rendered as results.py renders them and must be the
page's rows. With HAUSTRA_FULL_RUN set (`make test-release`), every row on the page must also have
been measured in this run; a partial run (`ctest -R`) checks only the rows it measured.
"""
import glob
import hashlib
import json
import os
import re
import subprocess
import sys
from collections import Counter

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import results  # noqa: E402  (the renderer of docs/results.md's rows)

STUDIES = "studies/include/haustra/studies/"
# page: (the command that regenerates it, the inputs in the repository that decide its content)
PAGES = {
    "docs/results.md": ("make results", ["scripts/results.py", "tests/support/measured.hpp",
                                         "studies/src/validation.cpp", "studies/src/references.cpp",
                                         STUDIES + "validation.hpp", STUDIES + "references.hpp"]),
    "docs/stability.md": ("make stability-doc", ["studies/src/stability.cpp", STUDIES + "stability.hpp",
                                                 "tests/data/stability-map.csv"]),
    "docs/tradeoff.md": ("make study", ["studies/src/tradeoff_*.cpp", "studies/src/tradeoff_knobs.hpp",
                                        "studies/src/grasp_push.cpp", STUDIES + "tradeoff_study.hpp",
                                        STUDIES + "grasp_push.hpp", "scenes/grasp-push.toml", "scenes/range-pull.toml"]),
    "docs/anatomy.md": ("make anatomy", ["studies/src/anatomy_cohort.cpp", STUDIES + "anatomy_cohort.hpp"]),
    "docs/studies-cohort.md": ("make studies-doc", ["python/studies/cohort.toml", "python/haustra/studies/*.py"]),
    "docs/skinning-table.md": ("make skinning-doc", ["studies/src/skinning_study.cpp", STUDIES + "skinning_study.hpp"]),
    "docs/skinning-anatomy.md": ("make skinning-doc", ["studies/src/skinning_study.cpp", "studies/src/anatomy_study.cpp",
                                                       STUDIES + "skinning_study.hpp", STUDIES + "anatomy_study.hpp"]),
}
# Hand-written pages that copy a generated page's tables: every table row must be there verbatim.
COPIES = {"docs/skinning.md": ["docs/skinning-table.md", "docs/skinning-anatomy.md"]}
STAMP = re.compile(r"^<!-- generated: inputs ([0-9a-f]+), text ([0-9a-f]+) \(scripts/pages\.py\).* -->$")


def digest(texts):
    h = hashlib.sha256()
    for name, text in texts:
        h.update(name.encode() + b"\0" + re.sub(rb"\s+", b"", text) + b"\0")
    return h.hexdigest()[:16]


# A C++ string or character literal (kept), or a comment (dropped).
CPP_TOKEN = re.compile(rb'"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\'|//[^\n]*|/\*.*?\*/', re.S)


def without_comments(name, text):
    if not name.endswith((".cpp", ".hpp", ".h", ".c")):
        return text
    text = CPP_TOKEN.sub(lambda m: m.group(0) if m.group(0)[:1] in (b'"', b"'") else b" ", text)
    return re.sub(rb'"\s*"', b"", text)  # adjacent literals are one (clang-format splits long ones)


def inputs_hash(page):
    files = sorted({f for pattern in PAGES[page][1] for f in glob.glob(os.path.join(ROOT, pattern))})
    missing = [p for p in PAGES[page][1] if not glob.glob(os.path.join(ROOT, p))]
    if missing:
        sys.exit(f"pages.py: {page}'s inputs {missing} are not in the repository: update PAGES in scripts/pages.py")
    texts = []
    for f in files:
        with open(f, "rb") as stream:
            name = os.path.relpath(f, ROOT)
            texts.append((name, without_comments(name, stream.read())))
    return digest(texts)


def split(page):
    """The page's lines without its stamp, and the stamp's match (None when it has none)."""
    with open(os.path.join(ROOT, page), encoding="utf-8") as f:
        lines = f.read().splitlines()
    stamp = STAMP.match(lines[-1]) if lines else None
    return (lines[:-1] if stamp else lines), stamp


def text_hash(lines):
    return digest([("page", "\n".join(lines).encode())])


def stamp(page):
    lines, _ = split(page)
    line = (f"<!-- generated: inputs {inputs_hash(page)}, text {text_hash(lines)} (scripts/pages.py); "
            f"regenerate with `{PAGES[page][0]}`, never by hand -->")
    with open(os.path.join(ROOT, page), "w", encoding="utf-8") as f:
        f.write("\n".join(lines + [line]) + "\n")


def figure_rows(record):
    with open(record) as f:
        figures = [json.loads(line) for line in f if line.strip()]
    return results.figure_rows(figures)[2:]


def table(heading):
    """docs/results.md's rows under a heading (the header and rule rows left out)."""
    lines, _ = split("docs/results.md")
    start = lines.index(heading)
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")), len(lines))
    return [l for l in lines[start:end] if l.startswith("| ") and not l.startswith("|---")][1:]


def check_validation(cli):
    done = subprocess.run([cli, "validate", "--json"], capture_output=True, text=True)
    rendered = results.validation_rows(json.loads(done.stdout))[2:]
    on_page = table(results.VALIDATION_HEADING)
    if rendered == on_page:
        return []
    return ([f"not on the page: {r}" for r in rendered if r not in on_page] +
            [f"not what `haustra validate` gives now: {r}" for r in on_page if r not in rendered] or
            ["the reference cases' order differs"])


def check_figures(record, full):
    on_page = Counter(table(results.FIGURES_HEADING))
    measured = Counter(figure_rows(record)) if os.path.exists(record) else Counter()
    problems = [f"measured in this run but not on the page: {r}" for r in (measured - on_page)]
    if full:
        problems += [f"on the page but not measured in this run: {r}" for r in (on_page - measured)]
    return problems, sum(measured.values()), sum(on_page.values())


def check(record, cli, full):
    stale = []
    for page, (command, _) in PAGES.items():
        lines, found = split(page)
        if not found:
            stale.append(f"{page}: no stamp of its inputs; regenerate it with `{command}`")
        elif found.group(1) != inputs_hash(page):
            stale.append(f"{page}: its inputs ({', '.join(PAGES[page][1])}) changed since it was written; "
                         f"regenerate it with `{command}`")
        elif found.group(2) != text_hash(lines):
            stale.append(f"{page}: edited by hand since it was generated; regenerate it with `{command}`")
    for copy, sources in COPIES.items():
        with open(os.path.join(ROOT, copy), encoding="utf-8") as f:
            held = set(f.read().splitlines())
        for source in sources:
            rows = [l for l in split(source)[0] if l.startswith("|") and l not in held]
            if rows:
                stale.append(f"{copy}: {len(rows)} table rows of {source} are not copied into it (first: {rows[0][:80]}); "
                             f"copy its tables after `{PAGES[source][0]}`")
    if cli is not None:
        problems = check_validation(cli)
        if problems:
            stale.append("docs/results.md: the reference cases differ from the page's; regenerate it with "
                         "`make results`:\n    " + "\n    ".join(problems))
    if record is not None:
        problems, measured, on_page = check_figures(record, full)
        if problems:
            stale.append("docs/results.md: the figures the tests measured differ from the page's; regenerate it "
                         "with `make results`:\n    " + "\n    ".join(problems))
        print(f"docs/results.md: {measured} figures measured in this run, {on_page} on the page"
              f"{'' if full else ' (a partial run: only the measured rows are checked)'}")
    for s in stale:
        print(s, file=sys.stderr)
    print(f"{len(PAGES)} generated pages, {len(stale)} stale")
    return 1 if stale else 0


def main():
    if len(sys.argv) >= 3 and sys.argv[1] == "stamp":
        for page in sys.argv[2:]:
            stamp(os.path.relpath(os.path.abspath(page), ROOT))
        return 0
    if len(sys.argv) >= 2 and sys.argv[1] == "check":
        options = dict(zip(sys.argv[2::2], sys.argv[3::2]))
        if set(options) - {"--figures", "--cli"} or len(sys.argv) % 2:
            sys.exit(__doc__)
        return check(options.get("--figures"), options.get("--cli"), bool(os.environ.get("HAUSTRA_FULL_RUN")))
    sys.exit(__doc__)


if __name__ == "__main__":
    sys.exit(main())
