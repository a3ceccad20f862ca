"""Runs a study's cells in-process or on Dask, writing each row as it arrives; a rerun skips the keys written."""
import contextlib
import csv
import io
import logging
import math
import multiprocessing
import os
import pathlib
import signal
import sys
import threading
import time

from .cells import GRID_METRICS, IMPORT_COLUMNS, KEY_COLUMNS, import_surface, run_cell

STABILITY_COLUMNS = ["youngs_modulus", "dt", "nodes", "load", "law", "frames", "outcome", "detail", "finite",
                     "names_cause", "fast_outcome", "fast_detail"]
TRADEOFF_COLUMNS = ["settings_errors", "knob_measured"]


def columns_for(study):
    if study.kind == "stability":
        return KEY_COLUMNS + STABILITY_COLUMNS
    if study.kind == "tradeoff":
        return KEY_COLUMNS + TRADEOFF_COLUMNS
    if study.kind == "empty":
        return KEY_COLUMNS + ["frames"]
    return KEY_COLUMNS + GRID_METRICS + (IMPORT_COLUMNS if study.imports else [])


def format_value(value):
    """One CSV field: floats as the shortest text that reads back to the same bits (repr)."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)
    return str(value)


def row_line(row, columns):
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerow([format_value(row.get(c)) for c in columns])
    return buffer.getvalue()


def read_rows(table, columns=None):
    """The rows of a results table (dicts of text), the last line dropped if a stop cut it short."""
    table = pathlib.Path(table)
    if not table.exists():
        return []
    with open(table, newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header is None:
            return []
        if columns is not None and header != columns:
            raise ValueError(f"{table}: its columns are not this study's (header {header[:4]}..., expected "
                             f"{columns[:4]}...): another study's table? Use another --out")
        return [dict(zip(header, r)) for r in reader if len(r) == len(header) and r[0]]


class RowWriter:
    """Appends rows to the table as they arrive, each flushed to disk; a key is written once."""

    def __init__(self, table, columns, written_rows):
        self.table, self.columns = pathlib.Path(table), columns
        self.keys = {r["key"] for r in written_rows}
        # Rewrite first: drops a line cut short by a stop, and starts a new table with its header.
        with open(self.table, "w", newline="") as f:
            f.write(",".join(columns) + "\n")
            for r in written_rows:
                f.write(row_line(r, columns))
        self.file = open(self.table, "a", newline="")

    def write(self, row):
        if row["key"] in self.keys:
            return False  # a cell Dask ran twice (its first worker died after finishing): kept once
        self.keys.add(row["key"])
        self.file.write(row_line(row, self.columns))
        self.file.flush()
        os.fsync(self.file.fileno())
        return True

    def close(self):
        self.file.close()


class Progress:
    """One line on stderr: cells done and failed of the total, elapsed, an estimate of what is left."""

    def __init__(self, name, total, skipped, stream=sys.stderr, enabled=True):
        self.name, self.total, self.skipped, self.stream, self.enabled = name, total, skipped, stream, enabled
        self.done = self.failed = 0
        self.start = time.monotonic()

    def update(self, row):
        self.done += 1
        self.failed += row["status"] != "ok"
        if not self.enabled:
            return
        elapsed = time.monotonic() - self.start
        left = self.total - self.skipped - self.done
        eta = elapsed / self.done * left if self.done else 0.0
        terminal = getattr(self.stream, "isatty", lambda: False)()  # a log or a pipe gets one line per update
        begin, end = ("\r", "   ") if terminal else ("", "\n")
        self.stream.write(f"{begin}{self.name}: {self.done + self.skipped}/{self.total} cells ({self.skipped} "
                          f"already written), {self.failed} failed, {elapsed:.0f} s elapsed, ~{eta:.0f} s left{end}")
        self.stream.flush()

    def finish(self):
        if self.enabled and getattr(self.stream, "isatty", lambda: False)():
            self.stream.write("\n")


def run_imported_cell(cell, imported, cell_runner=run_cell):
    """A surface study's cell once its surface is imported (Dask runs it after the import task)."""
    cell = dict(cell)
    if "error" in imported:
        cell["import_failed"] = imported["error"]
    else:
        cell["scene"] = imported["scene"]
        cell["import_report"] = dict(imported["report"], import_task_s=imported["seconds"])
    return cell_runner(cell)


def safe_import(surface, out, threads=1):
    """The import as a task that never raises: a failure is recorded in its cells' rows."""
    from .cells import first_line
    try:
        return import_surface(surface, out, threads)
    except Exception as e:  # noqa: BLE001
        return {"error": f"import: {first_line(e)}"}


def _client(scheduler, workers):
    """A Dask client: the scheduler at ADDRESS (or named by a scheduler file, as `dask-scheduler --scheduler-file`
    writes), or a local cluster of `workers` processes, one thread each (a world's threads are the cell's own,
    fixed in its overrides)."""
    from distributed import Client, LocalCluster
    if scheduler and pathlib.Path(scheduler).is_file():
        return Client(scheduler_file=str(scheduler)), None
    if scheduler:
        return Client(scheduler), None
    # The workers ignore Ctrl-C (a terminal sends it to the whole process group): the client stops the study and
    # closes the cluster, rather than each worker printing its own traceback. They inherit the disposition.
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        cluster = LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=40)
    finally:
        signal.signal(signal.SIGINT, previous)
    return Client(cluster), cluster


class Stopped(KeyboardInterrupt):
    """SIGINT (Ctrl-C) or SIGTERM (a batch system's stop): the study stops, the rows written stay, and a rerun
    runs only the cells missing."""


@contextlib.contextmanager
def stop_on_signals():
    """While a study runs, SIGINT and SIGTERM raise Stopped in the main thread (SIGTERM would otherwise end the
    process without closing a local cluster, whose workers would run on)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def stop(signum, _frame):
        raise Stopped(signal.Signals(signum).name)

    previous = {s: signal.signal(s, stop) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def _stop_cells(client, cluster, futures):
    """Nothing more runs: the cells not finished are cancelled and a local cluster's worker processes, busy or
    not, are killed (closing the cluster would wait for the cells they run); a remote scheduler's workers are
    its own, only told to cancel."""
    with contextlib.suppress(Exception):
        client.cancel(futures, force=True)
    if cluster is not None:
        for child in multiprocessing.active_children():
            with contextlib.suppress(Exception):
                child.kill()


def run_cells(study, todo, out, writer, progress, serial, scheduler, workers, cell_runner):
    imports_out = out / "imports"
    if serial:
        imported = {}
        for cell in todo:
            if cell.get("surface") is not None:
                if cell["surface"] not in imported:
                    imported[cell["surface"]] = safe_import(study.imports[cell["surface"]]["surface"], imports_out,
                                                            study.threads)
                row = run_imported_cell(cell, imported[cell["surface"]], cell_runner)
            else:
                row = cell_runner(cell)
            writer.write(row)
            progress.update(row)
        return
    from distributed import as_completed
    client, cluster = _client(scheduler, workers)
    futures, import_futures = [], {}
    stopped = False
    try:
        for cell in todo:
            if cell.get("surface") is not None:
                surface = cell["surface"]
                if surface not in import_futures:
                    import_futures[surface] = client.submit(safe_import, study.imports[surface]["surface"],
                                                            imports_out, study.threads,
                                                            key=f"import-{surface}-{cell['scene_hash']}")
                futures.append(client.submit(run_imported_cell, cell, import_futures[surface], cell_runner,
                                             key=f"cell-{cell['key']}"))
            else:
                futures.append(client.submit(cell_runner, cell, key=f"cell-{cell['key']}"))
        for future in as_completed(futures):
            row = future.result()
            writer.write(row)
            progress.update(row)
            future.release()
    except BaseException:  # a stop (Stopped) or a failure: no cell runs on
        stopped = True
        _stop_cells(client, cluster, futures + list(import_futures.values()))
        raise
    finally:
        # Dask's nanny logs a traceback for each worker process it finds killed, and its client's event loop
        # may log one for a comm the kill cut mid-call (asyncio's "Exception in callback"): here they were
        # killed on purpose, so both loggers are quiet while the cluster closes (and as they were afterwards).
        quiet = [logging.getLogger("distributed"), logging.getLogger("asyncio")]
        levels = [log.level for log in quiet]
        if stopped:
            for log in quiet:
                log.setLevel(logging.CRITICAL + 1)
        # A second Ctrl-C while closing is not a reason to leave the cluster behind.
        with contextlib.suppress(Exception, Stopped):
            client.close(timeout=10)
        if cluster is not None:
            with contextlib.suppress(Exception, Stopped):
                cluster.close(timeout=10)
        for log, level in zip(quiet, levels):
            log.setLevel(level)


def run_study(study, out, serial=False, scheduler=None, workers=None, cell_runner=run_cell, show_progress=True,
              retry_failed=False):
    """Runs the cells whose rows are not yet in OUT/results.csv; returns {'ran', 'skipped', 'failed', 'seconds',
    'rows', 'interrupted'} ('rows': this study's, in its cell order). Ctrl-C (KeyboardInterrupt, or SIGINT) or
    SIGTERM stops it: the rows written so far stay in the table, 'interrupted' names what stopped it ("SIGINT",
    "SIGTERM" or "Ctrl-C"; False when it ran to the end), and running it again runs only the rest. Rows of cells
    no longer in the study (a setting removed from the file) are kept, after this study's. A finished table is rewritten in the study's cell order, so it
    does not depend on where the cells ran."""
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    table = out / "results.csv"
    columns = columns_for(study)
    keys = {c["key"] for c in study.cells}
    kept = [r for r in read_rows(table, columns) if not (retry_failed and r["status"] != "ok" and r["key"] in keys)]
    done = {r["key"] for r in kept} & keys
    todo = [c for c in study.cells if c["key"] not in done]
    writer = RowWriter(table, columns, kept)
    progress = Progress(study.name, len(study.cells), len(done), enabled=show_progress)
    started = time.monotonic()
    interrupted = False
    try:
        if todo:
            with stop_on_signals():
                run_cells(study, todo, out, writer, progress, serial, scheduler, workers, cell_runner)
    except KeyboardInterrupt as stop:  # Ctrl-C, or Stopped: SIGINT or SIGTERM
        interrupted = stop.args[0] if isinstance(stop, Stopped) and stop.args else "Ctrl-C"
    finally:
        writer.close()
        progress.finish()
    seconds = time.monotonic() - started
    order = {c["key"]: i for i, c in enumerate(study.cells)}
    everything = read_rows(table, columns)
    rows = sorted((r for r in everything if r["key"] in keys), key=lambda r: order[r["key"]])
    others = [r for r in everything if r["key"] not in keys]
    if len(rows) == len(keys) and not interrupted:
        text = ",".join(columns) + "\n" + "".join(row_line(r, columns) for r in rows + others)
        (out / "results.csv.new").write_text(text)
        os.replace(out / "results.csv.new", table)
    return {"ran": progress.done, "skipped": len(done), "failed": sum(r["status"] != "ok" for r in rows),
            "seconds": seconds, "rows": rows, "interrupted": interrupted}
