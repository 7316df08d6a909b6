"""``kfio fit TRACE [--column NAME ...] [--sequence] [--level 0.95] [--json]``: a channel model for a packet trace.

Exit 0 on a fit, 2 on bad input (one line on stderr naming the field, e.g.
``TRACE line 7`` or ``--column``).  ``docs/traces.md`` walks through it.
"""

from __future__ import annotations

import argparse
import json
import os
from typing import Any

from .. import exitcodes
from ..io import add_time_budget_argument, dump_json, emit, run_guarded, time_budget


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "fit",
        help="fit a packet channel (Bernoulli, Gilbert-Elliott, Markov) to a measured trace, with confidence intervals",
        description="Fit the channel models kfio analyzes to a packet trace: exact maximum-likelihood estimates, "
        "model choice by BIC (Schwarz 1978), exact binomial intervals (Clopper and Pearson 1934) joint by Bonferroni, "
        "and a chi-square check of the loss-run lengths. Exit 0 on a fit, 2 on invalid input.",
    )
    p.add_argument("trace", metavar="TRACE", help="trace file (- for standard input): one 0/1 per line (1 = arrived)")
    p.add_argument(
        "--column",
        action="append",
        default=[],
        metavar="NAME",
        help="TRACE is a CSV file with a header row: fit the 0/1 column NAME (repeat for several sensors)",
    )
    p.add_argument(
        "--sequence",
        action="store_true",
        help="TRACE lists received sequence numbers, one per line: gaps are losses, duplicates and late packets "
        "are handled and reported",
    )
    p.add_argument(
        "--modulus",
        type=int,
        default=1 << 16,
        metavar="M",
        help="with --sequence: the counter wraps modulo M (default 65536; 0 for a counter that never wraps)",
    )
    p.add_argument(
        "--window",
        type=int,
        default=64,
        metavar="W",
        help="with --sequence: a packet may arrive up to W packets late (default 64); further back is refused",
    )
    p.add_argument("--level", default="0.95", metavar="L", help="joint confidence level in (0, 1) (default 0.95)")
    p.add_argument(
        "--model",
        choices=("bernoulli", "gilbert_elliott", "markov"),
        help="fit this model instead of choosing by BIC (markov needs --order)",
    )
    p.add_argument("--order", type=int, metavar="K", help="with --model markov: its order, 2..8")
    p.add_argument("--max-order", type=int, metavar="K", help="largest Markov order tried (default 4, at most 8)")
    p.add_argument(
        "--plant",
        metavar="FILE",
        help="with TRACE a folder: a request file whose system every trace's fitted channel is analyzed with "
        "(the exact verdict of the estimate and the verdict at --level confidence, per trace)",
    )
    p.add_argument("--json", action="store_true", help="print the JSON report instead of a summary")
    add_time_budget_argument(p, "default: none; past it the fit stops, exit 4")
    p.set_defaults(func=_run, quick_exit=True)


def _run(args: argparse.Namespace) -> int:
    def body() -> int:
        from kfio import Budget
        from kfio.errors import InvalidInput
        from kfio.fit import fit_trace, parse_level, read_trace

        if args.modulus < 0 or args.modulus == 1:
            raise InvalidInput("--modulus", "the modulus is an integer >= 2, or 0 for a counter that never wraps")
        level = parse_level(args.level, "--level")
        seconds = time_budget(args)
        budget = None if seconds is None else Budget(seconds=seconds)
        if os.path.isdir(args.trace):
            return _run_folder(args, level, budget)
        if args.plant is not None:
            raise InvalidInput(
                "--plant", "--plant is for a folder of traces; for one trace use kfio analyze PLANT --trace TRACE"
            )
        traces = read_trace(
            args.trace,
            columns=args.column,
            sequence=args.sequence,
            modulus=args.modulus or None,
            window=args.window,
        )
        reports = {}
        for name, trace in traces.items():
            try:
                reports[name] = fit_trace(
                    trace, level=level, model=args.model, order=args.order, max_order=args.max_order, budget=budget
                )
            except InvalidInput as exc:
                flag = {"/model": "--model", "/order": "--order", "/max_order": "--max-order"}.get(exc.field)
                where = flag or (f"--column {name}" if args.column else "TRACE")
                raise InvalidInput(where, exc.rule) from None
        if not args.column:
            report = reports["trace"]
            emit(dump_json(report.to_dict()) if args.json else report.summary())
            return exitcodes.STABLE
        if args.json:
            from kfio._version import __version__

            out = {
                "kfio_version": __version__,
                "fits": {name: r.to_dict() for name, r in reports.items()},
                "channel": {"model": "per_sensor", "channels": {name: r.channel for name, r in reports.items()}},
            }
            emit(dump_json(out))
        else:
            for name, r in reports.items():
                emit(f"column {name}:\n" + "\n".join("  " + line for line in r.summary().splitlines()))
            channels = {name: r.channel for name, r in reports.items()}
            emit("per-sensor channel: " + json.dumps({"model": "per_sensor", "channels": channels}))
        return exitcodes.STABLE

    return run_guarded(body)


def _folder_row(
    args: argparse.Namespace, path: str, level: Any, plant: Any, budget: Any = None
) -> list[dict[str, Any]]:
    """The rows of one file of a folder: one per trace (CSV column), or one error row naming the field."""
    from kfio.errors import InvalidInput
    from kfio.fit import analyze_at_confidence, fit_trace, read_trace, with_trace

    name = os.path.basename(path)
    rows: list[dict[str, Any]] = []
    try:
        traces = read_trace(
            path, columns=args.column, sequence=args.sequence, modulus=args.modulus or None, window=args.window
        )
        for column, trace in traces.items():
            row: dict[str, Any] = {"file": name, "column": column if args.column else None}
            if plant is None:
                row["fit"] = fit_trace(
                    trace, level=level, model=args.model, order=args.order, max_order=args.max_order, budget=budget
                ).to_dict()
            else:
                from kfio.stability import analyze

                request, found = with_trace(plant, trace, level)
                point = analyze(request, budget=budget).verdict
                row["fit"] = found.to_dict()
                row["verdict"] = str(point)
                row["confidence"] = analyze_at_confidence(request, found, point, budget).to_dict()
            rows.append(row)
    except InvalidInput as exc:
        rows.append({"file": name, "column": None, "error": {"field": exc.field, "rule": exc.rule}})
    return rows


def _run_folder(args: argparse.Namespace, level: Any, budget: Any = None) -> int:
    """``kfio fit FOLDER [--plant PLANT]``: every file of the folder, one row per trace; exit 8 if some failed."""
    from kfio._version import __version__

    plant = None
    if args.plant is not None:
        from kfio.fit import load_trace_request

        from ..io import read_request_text

        plant, _ = load_trace_request(read_request_text(args.plant))
    files = sorted(
        os.path.join(args.trace, f)
        for f in os.listdir(args.trace)
        if not f.startswith(".") and os.path.isfile(os.path.join(args.trace, f))
    )
    rows = [row for path in files for row in _folder_row(args, path, level, plant, budget)]
    if args.json:
        emit(dump_json({"kfio_version": __version__, "level": float(level), "traces": rows}))
    else:
        for row in rows:
            label = row["file"] + (f" [{row['column']}]" if row.get("column") else "")
            if "error" in row:
                emit(f"{label}: error at {row['error']['field']}: {row['error']['rule']}")
                continue
            f = row["fit"]
            params = ", ".join(f"{k} = {v}" for k, v in f["parameters"].items())
            line = f"{label}: {f['samples']} packets, {f['model']}" + (
                f" order {f['order']}" if f["model"] == "markov" else ""
            )
            line += f" ({params})"
            if "confidence" in row:
                c = row["confidence"]
                line += f"; estimate {row['verdict']}, at {float(level) * 100:g}% {c['verdict']}"
                if c["samples_needed"] is not None:
                    line += f" (about {c['samples_needed']} packets would decide)"
            emit(line)
    return exitcodes.SWEEP_ERRORS if any("error" in r for r in rows) else exitcodes.STABLE


def add_trace_arguments(p: argparse.ArgumentParser) -> None:
    """``--trace TRACE`` and ``--level L`` of ``kfio analyze`` and ``kfio loop``."""
    p.add_argument(
        "--trace",
        metavar="TRACE",
        help="fit the channel to this packet trace (one 0/1 per line, 1 = arrived) and add the verdict of the whole "
        "confidence region (the fit block); the headline stays the exact verdict of the fitted estimate",
    )
    p.add_argument(
        "--level", metavar="L", help="with --trace or a trace channel: joint confidence level (default 0.95)"
    )
    p.add_argument(
        "--trace-column",
        metavar="NAME",
        help="with --trace: TRACE is a CSV file with a header row; fit its 0/1 column NAME",
    )
    p.add_argument(
        "--trace-sequence",
        action="store_true",
        help="with --trace: TRACE lists received sequence numbers (16-bit counter, reordering window 64; "
        "kfio fit --sequence takes other values)",
    )


class TraceLoader:
    """The trace of ``--trace`` or of a ``{"model": "trace"}`` channel, and its fit, for one command run."""

    def __init__(self, args: argparse.Namespace, link: str = "/channel") -> None:
        self.args = args
        self.link = link
        self.fit: Any = None

    def load(self, data: bytes, limits: Any) -> Any:
        """The request of ``data`` with a trace channel fitted (:func:`kfio.fit.load_trace_request`)."""
        from kfio.fit import load_trace_request

        request, fits = load_trace_request(data, limits)
        self.fit = fits.get(self.link)
        return request

    def load_loop(self, data: bytes) -> Any:
        """The loop request of ``data``, with a trace channel (sensor or actuator) fitted."""
        from kfio.errors import InvalidInput
        from kfio.fit import load_trace_loop_request

        request, fits = load_trace_loop_request(data)
        if len(fits) > 1:
            raise InvalidInput("/actuator_channel", "one link at a time may be a trace; the sensor channel is one")
        for link, found in fits.items():
            self.link, self.fit = link, found
        return request

    def apply(self, request: Any) -> Any:
        """``request`` with ``--trace`` fitted in place of its channel (unchanged without ``--trace``)."""
        from kfio.errors import InvalidInput
        from kfio.fit import read_trace, refit, with_trace

        if self.args.trace is None:
            for flag, given in (
                ("--trace-column", self.args.trace_column),
                ("--trace-sequence", self.args.trace_sequence),
            ):
                if given:
                    raise InvalidInput(flag, f"{flag} needs --trace")
            if self.args.level is not None:
                if self.fit is None:
                    raise InvalidInput("--level", "--level needs --trace or a trace channel")
                self.fit = refit(self.fit, self.args.level)
            return request
        if self.fit is not None:
            raise InvalidInput("--trace", "the request's channel is already a trace; give one or the other")
        column = self.args.trace_column
        traces = read_trace(self.args.trace, columns=[column] if column else (), sequence=self.args.trace_sequence)
        (trace,) = traces.values()
        request, self.fit = with_trace(request, trace, self.args.level)
        return request
