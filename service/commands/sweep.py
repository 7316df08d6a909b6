"""``kfio sweep FILE [--out TABLE] [--plot PNG] [--scheduler ADDR]``: many points, one table.

A sweep is a base request plus axes (JSON pointers with values or ranges,
combined as a grid or zipped), or JSON Lines of whole requests.  Rows stream
to standard output as JSON Lines as they finish; ``--out`` writes the table
(CSV, Parquet or JSON Lines, by its suffix) in index order as the rows come,
so memory stays flat in the number of points (``--plot`` keeps every row).
Exit 0 every point answered, 8 some points have an error row, 4 the sweep's
time budget ran out, 2 invalid input (before any work starts), 9 a package
is missing (a broken install; ``--serial`` needs no Dask).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import threading
from typing import Any

from .. import exitcodes
from ..io import add_time_budget_argument, read_request_text, run_guarded, time_budget


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "sweep",
        help="run analyze/bounds/simulate over a grid of points or a list of requests (Dask)",
        description="Run one command over many points: a base request and axes (grid or zip), or JSON Lines "
        "of requests. Every point is validated before any work starts. Rows stream to stdout as JSON Lines. "
        "Exit 0 all points answered, 8 some points failed (their rows say why), 4 sweep budget ran out, "
        "2 invalid input, 9 a package is missing (--serial needs no Dask). Example: kfio sweep "
        "examples/sweeps/arrival_probability.json",
    )
    p.add_argument("file", metavar="FILE", help="sweep JSON (or JSON Lines of requests), or - for standard input")
    p.add_argument("--out", metavar="TABLE", help="write the table: .csv, .parquet or .jsonl")
    p.add_argument("--plot", metavar="PNG", help="write a plot of a 1-D or 2-D sweep")
    p.add_argument("--scheduler", metavar="ADDR", help="run on an existing Dask cluster, e.g. tcp://127.0.0.1:8786")
    p.add_argument(
        "--workers", type=int, metavar="N", help="run on an embedded cluster of N worker processes (default: cores)"
    )
    p.add_argument(
        "--serial",
        action="store_true",
        help="run in this process, without Dask (default: chosen by the work, in process for small sweeps)",
    )
    p.add_argument("--chunk-size", type=int, metavar="K", help="points per task (default: balanced, at most 2000)")
    add_time_budget_argument(
        p,
        "of the whole sweep; default: options.time_budget_s of the file, else none; points not done by then "
        "get budget-exceeded rows, exit 4",
    )
    p.add_argument("--quiet", action="store_true", help="do not stream rows to standard output")
    prog = p.add_mutually_exclusive_group()
    prog.add_argument("--progress", dest="progress", action="store_true", default=None, help="show a progress bar")
    prog.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    p.set_defaults(func=_run)


class _Bar:
    """A tqdm bar on stderr (with its ETA), or plain lines where tqdm is missing."""

    def __init__(self, total: int, enabled: bool):
        self.enabled = enabled
        self.bar: Any = None
        self.last = 0
        if enabled:
            try:
                from tqdm import tqdm

                self.bar = tqdm(total=total, unit="pt", file=sys.stderr, desc="sweep", dynamic_ncols=True)
            except ImportError:
                self.bar = None

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.update(done - self.last)
        else:
            print(f"sweep: {done}/{total} points", file=sys.stderr, flush=True)
        self.last = done

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _run(args: argparse.Namespace) -> int:
    def body() -> int:
        import time

        from kfio.errors import InvalidInput
        from kfio.sweep import (
            MAX_SWEEP_FILE_BYTES,
            SweepResult,
            TableWriter,
            format_of,
            in_index_order,
            iter_sweep,
            jsonl_line,
            load_sweep,
            record,
            table_columns,
        )

        for flag in ("workers", "chunk_size"):
            value = getattr(args, flag)
            if value is not None and value < 1:
                raise InvalidInput(f"--{flag.replace('_', '-')}", "must be a positive integer")
        if args.out:
            format_of(args.out)
        if args.plot and not args.plot.lower().endswith(".png"):
            raise InvalidInput("--plot", "the plot's file name must end in .png")
        seconds = time_budget(args)
        spec = load_sweep(read_request_text(args.file, MAX_SWEEP_FILE_BYTES, "a sweep file"))
        if seconds is not None:
            spec = dataclasses.replace(spec, time_budget_s=seconds)
        columns = table_columns(spec)
        enabled = sys.stderr.isatty() if args.progress is None else args.progress
        bar = _Bar(spec.size, enabled)
        info: dict[str, Any] = {}
        kept: list[Any] | None = [] if args.plot else None  # a plot needs every row; a table does not
        writer: TableWriter | None = None
        n = errors = 0
        budget_rows = False

        def streamed(rows: Any) -> Any:
            for row in rows:
                if not args.quiet:
                    print(jsonl_line(row.to_dict()), flush=False)
                yield row

        t0 = time.perf_counter()
        try:
            rows = iter_sweep(
                spec,
                engine="serial" if args.serial else ("dask" if args.scheduler or args.workers else "auto"),
                scheduler=args.scheduler,
                workers=args.workers,
                chunk_size=args.chunk_size,
                progress=bar,
                cancel=threading.Event(),
                info=info,
            )
            # rows print as they finish; the table is written in index order as it becomes known
            for row in in_index_order(streamed(rows)):
                n += 1
                error = row.fields.get("error")
                if error:
                    errors += 1
                    budget_rows = budget_rows or str(error).startswith("budget-exceeded: the sweep")
                if args.out:
                    if writer is None:  # opened at the first row: every point has been validated
                        writer = TableWriter(args.out, columns)
                    writer.write(record(row, columns))
                if kept is not None:
                    kept.append(row)
            if writer is not None:
                writer.close()
                writer = None
        finally:
            bar.close()
            sys.stdout.flush()
            if writer is not None:
                writer.abort()
        seconds = time.perf_counter() - t0
        if args.plot:
            from ..sweep_plot import sweep_png

            assert kept is not None
            with open(args.plot, "wb") as fh:
                fh.write(sweep_png(SweepResult.collect(spec, kept, info, seconds)))
        rate = n / seconds if seconds > 0 else float("inf")
        print(
            f"kfio sweep: {n} points, {errors} with errors, engine {info.get('engine', '?')} "
            f"({info.get('workers', 0)} workers, {info.get('chunks', 0)} tasks), {seconds:.2f} s, {rate:.1f} points/s"
            + (f"; {info['engine_reason']}" if info.get("engine_reason") else ""),
            file=sys.stderr,
        )
        if info.get("stopped") == "budget-exceeded" or budget_rows:
            return exitcodes.BUDGET
        return exitcodes.SWEEP_ERRORS if errors else exitcodes.STABLE

    return run_guarded(body)
