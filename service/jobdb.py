"""Where accepted jobs are kept: one small interface, in memory or in an embedded SQLite database.

:class:`kfio.service.jobstore.JobStore` runs jobs and holds them in memory for
polling; it writes every change of a job through a :class:`JobRecords`, so
that a restarted server, even after SIGKILL, finds every job it accepted.

* :class:`MemoryRecords` keeps nothing: jobs die with the process (the store of
  an app built without ``data_dir``, as the tests build it).
* :class:`SqliteRecords` keeps them in ``<data_dir>/jobs.sqlite3`` (standard
  library :mod:`sqlite3`, write-ahead log, ``synchronous=FULL``).  Every change
  is one transaction, so a write cut short by a kill leaves the job as it was
  before the write, never half of it.  A server takes an exclusive lock on
  ``<data_dir>/lock`` for as long as it runs: two servers never share one
  directory (SQLite's locks are not safe across hosts on network file systems,
  and two servers would both resume the same queued jobs).

A record is a plain dict with the members of :data:`COLUMNS`; ``params``,
``options``, ``progress`` and ``problem`` are JSON-able values, ``body`` and
``content`` bytes.
"""

from __future__ import annotations

import fcntl
import json
import os
import sqlite3
import threading
from pathlib import Path
from typing import Any, Iterable, Protocol

#: The members of a record, in the table's column order.
COLUMNS = (
    "id",
    "kind",
    "body",
    "params",
    "options",
    "budget_s",
    "status",
    "created",
    "started",
    "finished",
    "attempts",
    "content",
    "media_type",
    "problem",
)
_JSON_COLUMNS = frozenset({"params", "options", "problem"})

#: The file name of the database inside the data directory.
DB_NAME = "jobs.sqlite3"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS jobs (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    id TEXT NOT NULL UNIQUE,
    kind TEXT NOT NULL,
    body BLOB NOT NULL,
    params TEXT NOT NULL,
    options TEXT,
    budget_s REAL NOT NULL,
    status TEXT NOT NULL,
    created REAL NOT NULL,
    started REAL,
    finished REAL,
    attempts INTEGER NOT NULL DEFAULT 0,
    content BLOB,
    media_type TEXT,
    problem TEXT
)
"""


class StoreUnavailable(RuntimeError):
    """A job could not be written (the disk is full, the database is not writable); nothing was changed."""


class JobRecords(Protocol):
    """The persistence of jobs: every method is atomic, and raises :class:`StoreUnavailable` on a failed write."""

    durable: bool

    def add(self, record: dict[str, Any]) -> None:
        """Keep a newly accepted job."""

    def update(self, job_id: str, **members: Any) -> None:
        """Change some members of a job (its status, times, attempts, result)."""

    def remove(self, job_ids: Iterable[str]) -> None:
        """Forget jobs (their retention ended)."""

    def load(self) -> list[dict[str, Any]]:
        """Every kept job, in the order they were accepted."""

    def close(self) -> None:
        """Release the database and its lock."""


class MemoryRecords:
    """Keeps nothing: the job store's own memory is all there is (jobs end with the process)."""

    durable = False

    def add(self, record: dict[str, Any]) -> None:
        pass

    def update(self, job_id: str, **members: Any) -> None:
        pass

    def remove(self, job_ids: Iterable[str]) -> None:
        pass

    def load(self) -> list[dict[str, Any]]:
        return []

    def close(self) -> None:
        pass


class SqliteRecords:
    """Jobs in ``<data_dir>/jobs.sqlite3``, the directory locked for this process (see the module docstring).

    Raises
    ------
    RuntimeError
        The directory cannot be created, or another server holds its lock.
    """

    durable = True

    def __init__(self, data_dir: str | os.PathLike[str]) -> None:
        self.dir = Path(data_dir).expanduser()
        try:
            self.dir.mkdir(parents=True, exist_ok=True, mode=0o700)
            self._lock = open(self.dir / "lock", "a+")  # noqa: SIM115 - held for the store's life
        except OSError as exc:
            raise RuntimeError(
                f"cannot use the data directory {self.dir} (KFIO_DATA_DIR): {exc.strerror or exc}"
            ) from None
        try:
            fcntl.flock(self._lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self._lock.close()
            raise RuntimeError(
                f"the data directory {self.dir} (KFIO_DATA_DIR) is in use by another kfio server; "
                "give each server a directory of its own"
            ) from None
        self._mutex = threading.Lock()
        try:
            # autocommit mode: each method opens its own transaction explicitly
            self._db = sqlite3.connect(self.dir / DB_NAME, isolation_level=None, check_same_thread=False)
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=FULL")  # a 202 is sent after its job is on disk
            self._db.execute("PRAGMA busy_timeout=5000")
            self._db.execute(_SCHEMA)
        except sqlite3.Error as exc:
            self._lock.close()
            raise RuntimeError(f"cannot open the job database in {self.dir} (KFIO_DATA_DIR): {exc}") from None

    def _write(self, sql: str, rows: list[tuple[Any, ...]]) -> None:
        with self._mutex:
            try:
                self._db.execute("BEGIN IMMEDIATE")
                try:
                    self._db.executemany(sql, rows)
                except BaseException:
                    self._db.execute("ROLLBACK")
                    raise
                self._db.execute("COMMIT")
            except sqlite3.Error as exc:
                if self._db.in_transaction:  # a COMMIT that failed (a full disk): undo the whole write
                    try:
                        self._db.execute("ROLLBACK")
                    except sqlite3.Error:
                        pass  # SQLite rolls back itself when it cannot; the write is not committed either way
                raise StoreUnavailable(str(exc)) from None

    def add(self, record: dict[str, Any]) -> None:
        values = tuple(_encode(column, record.get(column)) for column in COLUMNS)
        marks = ", ".join("?" for _ in COLUMNS)
        self._write(f"INSERT INTO jobs ({', '.join(COLUMNS)}) VALUES ({marks})", [values])

    def update(self, job_id: str, **members: Any) -> None:
        unknown = set(members) - set(COLUMNS[1:])
        if unknown:
            raise ValueError(f"not columns of a job: {sorted(unknown)}")
        names = list(members)
        assignments = ", ".join(f"{name} = ?" for name in names)
        values = tuple(_encode(name, members[name]) for name in names)
        self._write(f"UPDATE jobs SET {assignments} WHERE id = ?", [(*values, job_id)])

    def remove(self, job_ids: Iterable[str]) -> None:
        rows = [(job_id,) for job_id in job_ids]
        if rows:
            self._write("DELETE FROM jobs WHERE id = ?", rows)

    def load(self) -> list[dict[str, Any]]:
        with self._mutex:
            cursor = self._db.execute(f"SELECT {', '.join(COLUMNS)} FROM jobs ORDER BY seq")
            return [
                {column: _decode(column, value) for column, value in zip(COLUMNS, row, strict=True)} for row in cursor
            ]

    def close(self) -> None:
        with self._mutex:
            self._db.close()
        self._lock.close()  # releases the lock


def _encode(column: str, value: Any) -> Any:
    if column in _JSON_COLUMNS:
        return None if value is None else json.dumps(value)
    return value


def _decode(column: str, value: Any) -> Any:
    if column in _JSON_COLUMNS:
        return None if value is None else json.loads(value)
    return value


def data_dir_problem(data_dir: str | os.PathLike[str]) -> str | None:
    """Why a server cannot keep its jobs in ``data_dir`` now (``None`` if it can): checked before it starts."""
    try:
        SqliteRecords(data_dir).close()
    except RuntimeError as exc:
        return str(exc)
    return None


def open_records(data_dir: str | None) -> JobRecords:
    """:class:`SqliteRecords` in ``data_dir``, or :class:`MemoryRecords` when it is ``None``."""
    return MemoryRecords() if data_dir is None else SqliteRecords(data_dir)


def default_data_dir() -> Path:
    """Where ``kfio serve`` keeps its jobs when ``KFIO_DATA_DIR`` is not set.

    ``$XDG_DATA_HOME/kfio``, else ``~/.local/share/kfio`` (the XDG base
    directory default); in the container image that is
    ``/home/kfio/.local/share/kfio``, declared as a volume.
    """
    xdg = os.environ.get("XDG_DATA_HOME")
    base = Path(xdg) if xdg and Path(xdg).is_absolute() else Path.home() / ".local" / "share"
    return base / "kfio"
