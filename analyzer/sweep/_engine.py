"""Run a sweep: serially in this process, or on Dask distributed.

The Dask engine chunks the points into tasks (thousands of points per task
where each is fast), so the scheduler never holds millions of tasks.  By
default it starts an embedded :class:`distributed.LocalCluster` (one worker
process per core, no external service); ``scheduler="tcp://HOST:PORT"`` runs
the same sweep on an existing cluster whose workers have kfio installed.

Faults: a worker that dies mid-task has its tasks rescheduled by Dask; each
task's result is taken once, so the table has exactly one row per point.  A
task that keeps killing workers gives ``worker-lost`` rows for its points; a
point that fails (budget, numerical failure) gets a row naming its error and
the sweep goes on.  A total budget and a cancel event stop the sweep; points
not reached get ``budget-exceeded`` or ``cancelled`` rows.
"""

from __future__ import annotations

import logging
import math
import os
import threading
import time
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Generator, Iterable, Iterator, Sequence

from .._reporting import Report, ReportPart
from ..errors import InvalidInput, MissingDependency
from ..model import DEFAULT_LIMITS, Limits, fraction_text
from ._evaluate import evaluate_chunk
from ._rows import FIELDS, coordinate_column, error_row
from ._spec import Axis, RationalRange, SweepSpec, check_points, coordinates_at, request_text

#: ``progress(done, total)`` after every finished chunk.
Progress = Callable[[int, int], None]

#: Points per task at most, and tasks per worker at least (for balance).
MAX_CHUNK = 2000
TASKS_PER_WORKER = 8
#: Tasks still running this long after the sweep's deadline are abandoned (each point also has its own budget).
_GRACE_S = 5.0

#: ``engine="auto"``: the in-process work (seconds, estimated from the first points) below which a
#: sweep stays in this process.  The embedded cluster costs an overhead (start-up, its workers'
#: imports, shut-down) before it divides the work by its ``W`` workers, so it wins once the work
#: exceeds ``overhead x W / (W - 1)``: with 2 workers about 3 s on a quiet machine (overhead 1.5 s)
#: and 7 s to 30 s on the shared 2-core machine under load (overhead 3.4 s median, up to 15 s).
#: Measured by ``bench/bench_sweep_engine.py`` (docs/sweeps.md has the table).
AUTO_SERIAL_WORK_S = 10.0
#: ``engine="auto"`` times the first points in this process until this many seconds or points pass.
AUTO_PROBE_S = 0.5
AUTO_PROBE_POINTS = 16


@dataclass(frozen=True)
class SweepRow(ReportPart):
    """One finished point: index, coordinates (axis name -> exact value text) and fields.

    :meth:`exact_of` reads ``fields``: ``row.exact_of("critical_arrival_probability")``.
    """

    index: int
    coordinates: dict[str, Any]
    fields: dict[str, Any]

    def exact_names(self) -> tuple[str, ...]:
        """The names :meth:`exact_of` accepts: every key ``X`` of ``fields`` with an exact text ``X_exact``."""
        return tuple(sorted(k.removesuffix("_exact") for k in self.fields if k.endswith("_exact")))

    def _exact_pair(self, key: str) -> tuple[Any, Any]:
        return self.fields.get(key + "_exact"), self.fields.get(key)


@dataclass(repr=False)
class SweepResult(Report):
    """All rows of a sweep, in index order, with how it ran."""

    _repr_fields: ClassVar[tuple[str, ...]] = ("engine", "workers", "chunks", "seconds", "stopped")

    spec: SweepSpec
    rows: list[SweepRow]
    engine: str
    workers: int
    chunks: int
    seconds: float
    stopped: str | None = None
    stats: dict[str, Any] = field(default_factory=dict)

    def _repr_items(self) -> list[tuple[str, Any]]:
        return [("command", self.spec.command), ("points", len(self.rows)), *super()._repr_items()]

    @classmethod
    def collect(cls, spec: SweepSpec, rows: list[SweepRow], info: dict[str, Any], seconds: float) -> SweepResult:
        """The result of rows from :func:`iter_sweep` (any order) and the ``info`` it filled."""
        rows = sorted(rows, key=lambda r: r.index)
        if len(rows) != spec.size or any(r.index != i for i, r in enumerate(rows)):  # pragma: no cover - invariant
            raise AssertionError("a sweep must give exactly one row per point")
        return cls(
            spec,
            rows,
            info.get("engine", "?"),
            info.get("workers", 0),
            info.get("chunks", 0),
            seconds,
            info.get("stopped"),
        )

    @property
    def columns(self) -> list[str]:
        """``index``, ``axis:<name>`` per axis, the command's fields (:data:`FIELDS`), ``error``."""
        return table_columns(self.spec)

    def records(self) -> list[dict[str, Any]]:
        """One JSON record per row, in index order, with exactly :attr:`columns` (each row encoded once)."""
        cols = self.columns
        return [record(r, cols) for r in self.rows]


def record(row: SweepRow, columns: Sequence[str]) -> dict[str, Any]:
    """The table record of ``row``: its JSON (:meth:`SweepRow.to_dict`, encoded once) keyed by ``columns``.

    A row's fields come from the workers already encoded, so its view is
    usually JSON as it stands: when every value is one the encoder returns
    unchanged (text, an integer, a boolean, ``None``, a finite float), the
    view is the JSON and the encoder is not run; anything else goes through it.
    """
    from .._json import view_of

    view = view_of(SweepRow)
    assert view is not None
    d = view(row)
    if not all(type(v) in _AS_IS or (type(v) is float and math.isfinite(v)) for v in d.values()):
        d = row.to_dict()
    return {c: d.get(c) for c in columns}


#: Types :func:`kfio._json.encode` returns unchanged (and ``float`` when finite).
_AS_IS = frozenset({str, int, bool, type(None)})


def in_index_order(rows: Iterable[SweepRow], start: int = 0) -> Iterator[SweepRow]:
    """``rows`` (any order, each index once from ``start`` on) in index order, as soon as each can go.

    Rows that arrive ahead of a missing index wait in a buffer until it
    comes: the engines finish chunks of consecutive points nearly in order,
    so the buffer holds a few chunks, not the table.
    """
    ahead: dict[int, SweepRow] = {}
    nxt = start
    for r in rows:
        ahead[r.index] = r
        while nxt in ahead:
            yield ahead.pop(nxt)
            nxt += 1
    for i in sorted(ahead):  # pragma: no cover - only if an index never came (an engine bug)
        yield ahead.pop(i)


def table_columns(spec: SweepSpec) -> list[str]:
    """The table's columns: ``index``, ``axis:<name>`` per axis, the command's fields (:data:`FIELDS`), ``error``."""
    coordinates = [coordinate_column(name) for name in spec.coordinate_names]
    return ["index", *coordinates, *FIELDS[spec.command], "error"]


def chunk_size_for(n_points: int, workers: int, requested: int | None = None) -> int:
    """Points per task: ``requested``, else enough tasks for balance, at most :data:`MAX_CHUNK`."""
    if requested is not None:
        return requested
    return max(1, min(MAX_CHUNK, math.ceil(n_points / max(1, workers * TASKS_PER_WORKER))))


def _canonical(spec: SweepSpec) -> str:
    obj: dict[str, Any] = {
        "command": spec.command,
        "combine": spec.combine,
        "options": {"point_budget_s": repr(spec.point_budget_s)},
    }
    if spec.requests is not None:
        obj["requests"] = list(spec.requests)
    else:
        obj["base"] = spec.base
        obj["axes"] = [_canonical_axis(a) for a in spec.axes]
    return request_text(obj)


def _canonical_axis(axis: Axis) -> dict[str, Any]:
    """An axis as canonical JSON: a range stays ``from``, ``to``, ``num`` (never its list of values)."""
    if isinstance(axis.values, RationalRange):
        r = axis.values
        return {
            "pointer": axis.pointer,
            "name": axis.name,
            "from": fraction_text(r.lo),
            "to": fraction_text(r.hi),
            "num": r.num,
        }
    return {"pointer": axis.pointer, "name": axis.name, "values": list(axis.values)}


def iter_sweep(
    spec: SweepSpec,
    *,
    engine: str = "auto",
    scheduler: str | None = None,
    workers: int | None = None,
    chunk_size: int | None = None,
    progress: Progress | None = None,
    cancel: threading.Event | None = None,
    reuse: bool = True,
    info: dict[str, Any] | None = None,
    limits: Limits = DEFAULT_LIMITS,
    validated: bool = False,
) -> Iterator[SweepRow]:
    """Rows as they finish (completion order).  Every point is validated before any work starts.

    Parameters
    ----------
    engine:
        ``"auto"`` (the default: chosen by the work, see :func:`_auto_probe`), ``"dask"`` (an
        embedded LocalCluster, or ``scheduler``) or ``"serial"`` (this process).
    scheduler:
        Address of a running Dask scheduler, e.g. ``tcp://127.0.0.1:8786``.
    workers:
        Worker processes of the embedded cluster (default: the machine's cores).
    reuse:
        Keep FMO blocks and verdicts across points (see :mod:`kfio.sweep._evaluate`);
        ``False`` analyses every point from scratch (the benchmark's baseline).
    info:
        Filled with ``engine``, ``workers``, ``chunks`` and ``stopped`` as the sweep runs, and
        with ``engine_reason`` (why that engine) when ``engine="auto"`` chose it.
    limits:
        The size limits every point is validated with.
    validated:
        The caller has already run :func:`check_points` with ``limits`` (skip it here).
    """
    if not validated:
        check_points(spec, limits)  # every point, before any work; none is kept (memory flat in the points)
    total = spec.size
    text = _canonical(spec)
    deadline = None if spec.time_budget_s is None else time.time() + spec.time_budget_s
    info = info if info is not None else {}
    info.update(stopped=None)
    first = 0
    if engine == "auto":
        if scheduler:
            engine = "dask"
            info["engine_reason"] = "a scheduler was named"
        else:
            probed: list[SweepRow] = []
            engine = yield from _auto_probe(spec, text, deadline, reuse, probed, info, cancel)
            first = len(probed)
            if progress is not None and first:
                progress(first, total)
    if engine == "serial":
        size = chunk_size_for(total, 1, chunk_size or spec.chunk_size)
        info.update(engine="serial", workers=1, chunks=math.ceil((total - first) / size) + (1 if first else 0))
        done = first
        for start in range(first, total, size):
            if cancel is not None and cancel.is_set():
                info["stopped"] = "cancelled"
                for i in range(start, total):
                    yield _row(spec, i, error_row(spec.command, "cancelled", "the sweep was cancelled"))
                return
            for i, row in evaluate_chunk(text, range(start, min(total, start + size)), deadline, reuse):
                yield _row(spec, i, row)
            done = min(total, start + size)
            if progress is not None:
                progress(done, total)
        return
    if engine != "dask":
        raise InvalidInput("/engine", "expected 'auto', 'dask' or 'serial'")
    yield from _iter_dask(spec, text, deadline, scheduler, workers, chunk_size, progress, cancel, reuse, info, first)


def _auto_probe(
    spec: SweepSpec,
    text: str,
    deadline: float | None,
    reuse: bool,
    probed: list[SweepRow],
    info: dict[str, Any],
    cancel: threading.Event | None,
) -> Generator[SweepRow, None, str]:
    """Run the first points here, timed; return ``"serial"`` or ``"dask"`` for the rest (a generator's return).

    The cost of a point is taken from the points after the first (the first pays this process's
    imports and fills the per-plant memo that the rest reuse); the rest of the sweep is
    ``cost x points left``.  Below :data:`AUTO_SERIAL_WORK_S` the sweep stays in this process;
    above it the embedded cluster takes the points left.  ``info["engine_reason"]`` says which
    and why, with the numbers.
    """
    total = spec.size
    t0 = time.perf_counter()
    stamps = [t0]
    while len(probed) < min(total, AUTO_PROBE_POINTS):
        if cancel is not None and cancel.is_set():
            break
        i = len(probed)
        for j, fields in evaluate_chunk(text, range(i, i + 1), deadline, reuse):
            row = _row(spec, j, fields)
            probed.append(row)
            yield row
        stamps.append(time.perf_counter())
        if len(probed) >= 2 and stamps[-1] - stamps[1] >= AUTO_PROBE_S:
            break  # timed long enough after the first point (which pays the imports)
    done = len(probed)
    left = total - done
    if left == 0 or (cancel is not None and cancel.is_set()):
        info["engine_reason"] = f"in process: all {total} points ran while timing the first ones"
        return "serial"
    per_point = (stamps[-1] - stamps[1]) / (done - 1) if done >= 2 else stamps[-1] - stamps[0]
    work = per_point * left
    if work < AUTO_SERIAL_WORK_S:
        info["engine_reason"] = (
            f"in process: {left} points left x {1000 * per_point:.3g} ms = {work:.2g} s, "
            f"below the {AUTO_SERIAL_WORK_S:g} s at which the embedded cluster pays off"
        )
        return "serial"
    info["engine_reason"] = (
        f"embedded cluster: {left} points left x {1000 * per_point:.3g} ms = {work:.2g} s, "
        f"above the {AUTO_SERIAL_WORK_S:g} s at which it pays off"
    )
    return "dask"


def _row(spec: SweepSpec, index: int, fields: dict[str, Any]) -> SweepRow:
    return SweepRow(index, coordinates_at(spec, index), fields)


def _iter_dask(
    spec: SweepSpec,
    text: str,
    deadline: float | None,
    scheduler: str | None,
    workers: int | None,
    chunk_size: int | None,
    progress: Progress | None,
    cancel: threading.Event | None,
    reuse: bool,
    info: dict[str, Any],
    first: int = 0,
) -> Iterator[SweepRow]:
    try:
        from distributed import Client, LocalCluster, as_completed
    except ImportError:  # a regular dependency: missing only in a broken install
        raise MissingDependency(
            "distributed", "the Dask sweep engine", "or run in this process: kfio sweep --serial FILE"
        ) from None
    total = spec.size
    cluster = None
    try:
        if scheduler:
            try:
                client = Client(scheduler, timeout=5)
            except OSError as exc:
                raise InvalidInput("/scheduler", f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        else:
            n = workers or os.cpu_count() or 1
            cluster = LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
            client = Client(cluster)
        n_workers = max(1, len(client.scheduler_info().get("workers", {})) or (workers or 1))
        size = chunk_size_for(total - first, n_workers, chunk_size or spec.chunk_size)
        starts = list(range(first, total, size))
        info.update(engine="dask", workers=n_workers, chunks=len(starts), scheduler=scheduler or "local")
        futures = {}
        for start in starts:
            idx = range(start, min(total, start + size))  # pickles as two integers
            fut = client.submit(evaluate_chunk, text, idx, deadline, reuse, pure=False, retries=1)
            futures[fut] = idx
        pending = set(futures)
        done_points = first
        seq = as_completed(list(futures), with_results=False)
        try:
            while pending:
                if cancel is not None and cancel.is_set():
                    info["stopped"] = "cancelled"
                    break
                if deadline is not None and time.time() > deadline + _GRACE_S:
                    info["stopped"] = "budget-exceeded"
                    break
                fut = _wait_next(seq, 0.25)
                if fut is None or fut not in pending:
                    continue
                pending.discard(fut)
                idx = futures.pop(fut)  # the future goes: the cluster forgets its rows once they are read
                try:
                    rows = fut.result()
                except Exception as exc:  # noqa: BLE001 - KilledWorker and friends: the rows say so
                    rows = [(i, error_row(spec.command, "worker-lost", f"{type(exc).__name__}: {exc}")) for i in idx]
                del fut
                for i, row in rows:
                    yield _row(spec, i, row)
                done_points += len(idx)
                if progress is not None:
                    progress(done_points, total)
        finally:
            if pending:
                client.cancel(list(pending))
        kind = info.get("stopped") or "budget-exceeded"
        message = "the sweep was cancelled" if kind == "cancelled" else "the sweep's time budget ran out"
        for fut in pending:
            for i in futures[fut]:
                yield _row(spec, i, error_row(spec.command, kind, message))
    finally:
        if "client" in locals():
            client.close()
        if cluster is not None:
            cluster.close()


def _wait_next(seq: Any, seconds: float) -> Any:
    """The next finished future of a :class:`distributed.as_completed`, or ``None`` after ``seconds``."""
    end = time.monotonic() + seconds
    while True:
        if seq.has_ready():
            return next(seq)
        if time.monotonic() >= end:
            return None
        time.sleep(0.01)


def run_sweep(spec: SweepSpec, **kwargs: Any) -> SweepResult:
    """Run a whole sweep and return its rows in index order (see :func:`iter_sweep`)."""
    info: dict[str, Any] = {}
    t0 = time.perf_counter()
    rows = list(iter_sweep(spec, info=info, **kwargs))
    return SweepResult.collect(spec, rows, info, time.perf_counter() - t0)
