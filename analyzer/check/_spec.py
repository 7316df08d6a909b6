"""Check files: plants and channels by file, and the requirements each pair must meet.

A check file is JSON (numbers keep their decimal text, as in a request) or
TOML (read by :mod:`tomllib` with floats as :class:`decimal.Decimal`, so
``0.1`` is ``1/10`` exactly)::

    {
      "options": {"time_budget_s": 300, "point_budget_s": 60},
      "checks": [
        {"name": "pendulum on the shop-floor radio",
         "plant": "plants/pendulum.json",
         "channel": "channels/radio.json",
         "requirements": {"verdict": "stable", "margin": "1/10"}}
      ]
    }

``plant`` and ``channel`` are paths relative to the check file.  A plant file
holds ``{"system": {...}}`` (a whole request is fine: its channel is used when
the entry names none) or the bare system object; a channel file holds
``{"channel": {...}}`` or the bare channel object.  ``options`` of an entry are
the request's ``options`` (e.g. ``{"bounds": {"horizon": 4}}``).  Every entry
is validated as a request before any work starts; an error names the field of
the check file (``/checks/2/plant``) and, inside the named file, its field.

An entry may name a measured packet trace instead of a channel
(``"trace": "traces/radio.txt"``, one 0/1 per line, and optionally
``"level": 0.95``): the channel is the one :func:`kfio.fit.fit` fits to it,
and ``verdict`` is then judged on the verdict of the whole confidence region
(``docs/traces.md``).

An entry may instead name a loop request file (``"loop": "loops/pendulum.json"``,
the file of ``kfio loop``, ``docs/loop.md``) with the loop requirements
(``loop_verdict``, ``loop_cost_at_most``,
``critical_sensor_arrival_probability_at_most``,
``critical_actuator_arrival_probability_at_most``); it then names no plant
or channel.

A check file reads only what it owns.  It may come from anyone (a pull
request that CI checks), so every path it names must resolve, symlinks
followed, to a regular file inside the check file's directory, or inside a
directory the caller allows (``allow_outside``, ``kfio check
--allow-outside DIR``).  Anything else (``..`` out of it, an absolute path
elsewhere, a symlink out, a FIFO, a device, a directory, a missing file) is
refused before it is opened, with one message whatever the reason, so an
error never tells whether a file outside exists.  The file is stat-ed first
and opened only if regular, with ``O_NONBLOCK`` and ``O_NOFOLLOW`` as a
second guard (a FIFO swapped in between cannot block).  Errors about what a
referenced file holds name the file and the field, never the value
(:func:`kfio.model.values_withheld`).
"""

from __future__ import annotations

import os
import stat
import tomllib
from collections.abc import Iterable
from dataclasses import dataclass, field
from decimal import Decimal
from pathlib import Path
from typing import Any, Mapping

from ..errors import InvalidInput
from ..model import (
    DEFAULT_LIMITS,
    MAX_CHECK_ENTRIES,
    MAX_RUN_BUDGET_S,
    fraction_text,
    json_pointer,
    load_json,
    parse_number,
    parse_request,
    value_text,
    values_withheld,
)
from ._requirements import OUTAGE_KEYS, Requirement, parse_requirements

CHECK_TOP_KEYS = {"$schema", "description", "options", "checks"}
CHECK_ENTRY_KEYS = {"name", "description", "plant", "channel", "trace", "level", "loop", "options", "requirements"}
CHECK_OPTION_KEYS = {"time_budget_s", "point_budget_s"}

#: Defaults of the whole check's budget and of each evaluation's (seconds).
DEFAULT_TIME_BUDGET_S = 600.0
DEFAULT_POINT_BUDGET_S = 120.0

#: Largest check file, plant file or channel file read (bytes).
MAX_FILE_BYTES = 1 << 20
MAX_ENTRIES = MAX_CHECK_ENTRIES


@dataclass(frozen=True)
class CheckEntry:
    """One plant and channel and the requirements on them.

    ``request`` is the JSON tree of the request (``system``, ``channel``,
    ``options``), already validated by :func:`kfio.parse_request`.
    """

    name: str
    request: dict[str, Any]
    requirements: tuple[Requirement, ...]

    @property
    def commands(self) -> tuple[str, ...]:
        """The commands whose reports judge this entry's requirements, in a fixed order."""
        needed = {r.command for r in self.requirements}
        return tuple(c for c in ("analyze", "bounds", "simulate", "loop") if c in needed)

    def request_for(self, command: str) -> dict[str, Any]:
        """The request tree ``command`` runs: for simulate, with the outage requirement's threshold and settings."""
        tree = dict(self.request)
        if command != "simulate":
            return tree
        outage = next(r.value for r in self.requirements if r.key == "outage")
        options = dict(tree.get("options") or {})
        sim = dict(options.get("simulate") or {})
        sim["outage_thresholds"] = [fraction_text(outage["threshold"])]
        sim.update({k: outage[k] for k in ("trajectories", "steps", "seed") if k in outage})
        options["simulate"] = sim
        tree["options"] = options
        return tree


def resolved(tree: dict[str, Any]) -> dict[str, Any]:
    """``tree`` with a trace channel replaced by the channel fitted to it (:func:`kfio.fit.resolve_traces`)."""
    from ..fit import resolve_traces

    out: dict[str, Any] = resolve_traces(tree)[0]
    return out


def _trace_channel(entry: Mapping[str, Any], roots: _Roots, where: str) -> dict[str, Any]:
    """The trace channel object of an entry naming ``trace`` (and optionally ``level``)."""
    from ..fit import fit_link

    if "channel" in entry:
        raise InvalidInput(f"{where}/trace", "an entry names a channel or a trace, not both")
    if "trace" not in entry:
        raise InvalidInput(f"{where}/level", "a confidence level needs a trace")
    ref = entry["trace"]
    if not isinstance(ref, str) or not ref.strip():
        raise InvalidInput(
            f"{where}/trace", "expected the path of a trace file (one 0/1 per line), relative to the check file"
        )
    try:
        text = _read_confined(ref, roots, f"{where}/trace", "trace file").decode("utf-8")
    except UnicodeDecodeError:
        raise InvalidInput(f"{where}/trace", f"{ref}: not UTF-8 text") from None
    channel: dict[str, Any] = {"model": "trace", "arrivals": text}
    if "level" in entry:
        channel["level"] = entry["level"]
    try:
        fit_link(channel, "/channel")
    except InvalidInput as exc:
        field_ = f"{where}/level" if exc.field == "/channel/level" else f"{where}/trace"
        raise InvalidInput(field_, f"{ref}: {exc.rule}" if field_.endswith("trace") else exc.rule) from None
    return channel


def _validate_options(entry: CheckEntry, where: str) -> None:
    """Check each command's options now (a Monte Carlo too large is a bad file, exit 2, not a failed run)."""
    for command in entry.commands:
        try:
            request = parse_request(resolved(entry.request_for(command)), DEFAULT_LIMITS.for_command(command))
            if command == "simulate":
                from ..simulation import parse_options

                parse_options(request)
            elif command == "bounds":
                from ..riccati_bounds import parse_bounds_options

                parse_bounds_options(request)
        except InvalidInput as exc:
            key = exc.field.removeprefix("/options/simulate/").split("/")[0]
            if command == "simulate" and exc.field.startswith("/options/simulate/") and key in OUTAGE_KEYS:
                raise InvalidInput(f"{where}/requirements/outage", f"{exc.field}: {exc.rule}") from None
            raise InvalidInput(f"{where}/options", f"{exc.field}: {exc.rule}") from None


@dataclass(frozen=True)
class CheckSpec:
    """A validated check file."""

    entries: tuple[CheckEntry, ...]
    time_budget_s: float = DEFAULT_TIME_BUDGET_S
    point_budget_s: float = DEFAULT_POINT_BUDGET_S
    source: str = field(default="<check>")

    @property
    def size(self) -> int:
        """The number of requirements."""
        return sum(len(e.requirements) for e in self.entries)


class _NotRegular(OSError):
    """The path names no regular file (a FIFO, a device, a directory, a socket)."""


def _read_regular(path: str) -> bytes:
    """The bytes of the regular file at ``path``, at most ``MAX_FILE_BYTES + 1`` of them.

    Stat first, open only a regular file: ``open()`` of a FIFO blocks until a
    writer comes, before any budget runs.  ``O_NONBLOCK`` and ``O_NOFOLLOW``
    guard the gap between the stat and the open (a FIFO or a symlink put in its
    place), and ``fstat`` checks that the file opened is the one stat-ed.
    """
    before = os.stat(path)
    if not stat.S_ISREG(before.st_mode):
        raise _NotRegular(path)
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0))
    try:
        after = os.fstat(fd)
        if not stat.S_ISREG(after.st_mode) or (after.st_dev, after.st_ino) != (before.st_dev, before.st_ino):
            raise _NotRegular(path)
        chunks = []
        left = MAX_FILE_BYTES + 1
        while left > 0:
            chunk = os.read(fd, min(left, 1 << 16))
            if not chunk:
                break
            chunks.append(chunk)
            left -= len(chunk)
        return b"".join(chunks)
    finally:
        os.close(fd)


def _read(path: Path, field_: str, what: str) -> bytes:
    """The check file itself (named by the caller, not by a file): a regular file, read without blocking."""
    try:
        data = _read_regular(str(path))
    except _NotRegular:
        raise InvalidInput(field_, f"the {what} {value_text(str(path), 100)} is not a regular file") from None
    except OSError as exc:
        raise InvalidInput(field_, f"cannot read the {what} {value_text(str(path), 100)}: {exc.strerror}") from None
    if len(data) > MAX_FILE_BYTES:
        raise InvalidInput(field_, f"the {what} {value_text(str(path), 100)} is larger than {MAX_FILE_BYTES} bytes")
    return data


@dataclass(frozen=True)
class _Roots:
    """Where a check file's paths may lead: its own directory, and the directories allowed outside it."""

    base: Path
    allowed: tuple[str, ...]

    @classmethod
    def of(cls, base: Path, allow_outside: Iterable[str | Path] = ()) -> _Roots:
        return cls(base, tuple(os.path.realpath(d) for d in (base, *allow_outside)))

    def confined(self, ref: str) -> str | None:
        """The real path ``ref`` leads to (symlinks followed), or ``None`` when it leaves every allowed directory."""
        real = os.path.realpath(self.base / ref)
        for root in self.allowed:
            if os.path.commonpath([real, root]) == root:
                return real
        return None


def _refusal(ref: str, what: str, roots: _Roots) -> str:
    """One rule for a missing file, a path outside, a FIFO or a directory: it must not tell which."""
    where = "the check file's directory" + (
        " or a directory given by --allow-outside" if len(roots.allowed) > 1 else ""
    )
    return (
        f"the {what} {value_text(ref, 100)} is not a regular file inside {where} (a check file may name only "
        "regular files under its own directory, symlinks followed: no '..' or absolute path out of it, no FIFO, "
        "device or directory; --allow-outside DIR allows another directory)"
    )


def _read_confined(ref: str, roots: _Roots, field_: str, what: str) -> bytes:
    """The bytes of the file ``ref`` names, relative to the check file, if it is a regular file it may read."""
    try:
        real = roots.confined(ref)
        if real is None:
            raise _NotRegular(ref)
        data = _read_regular(real)
    except (OSError, ValueError):  # ValueError: a NUL byte in the path
        raise InvalidInput(field_, _refusal(ref, what, roots)) from None
    if len(data) > MAX_FILE_BYTES:
        raise InvalidInput(field_, f"the {what} {value_text(ref, 100)} is larger than {MAX_FILE_BYTES} bytes")
    return data


def load_tree(data: bytes, name: str) -> Any:
    """The JSON tree of a JSON or TOML file's bytes (TOML when ``name`` ends in ``.toml``); numbers exact."""
    if name.lower().endswith(".toml"):
        try:
            return tomllib.loads(data.decode("utf-8"), parse_float=Decimal)
        except UnicodeDecodeError as exc:
            raise InvalidInput("/", f"not UTF-8 text ({exc.reason})") from None
        except tomllib.TOMLDecodeError as exc:
            raise InvalidInput("/", f"not valid TOML: {exc}") from None
    return load_json(data)


def _part(ref: Any, roots: _Roots, field_: str, what: str, key: str | None) -> tuple[Any, Any]:
    """The object under ``key`` in the file ``ref`` names (or the bare object; ``key`` None: the file), and the file."""
    if not isinstance(ref, str) or not ref.strip():
        raise InvalidInput(field_, f"expected the path of a {what} file, relative to the check file")
    data = _read_confined(ref, roots, field_, f"{what} file")
    try:
        with values_withheld():
            tree = load_tree(data, ref)
    except InvalidInput as exc:
        raise InvalidInput(field_, f"{value_text(ref, 100)}: {exc.rule}") from None
    if not isinstance(tree, dict):
        raise InvalidInput(field_, f"{value_text(ref, 100)}: expected a JSON object")
    return (tree[key] if key is not None and key in tree else tree), tree


def _in_file(entry: Mapping[str, Any], key: str) -> str:
    """`` (in the plant file plants/x.json)``: which file holds the field an error names."""
    ref = entry.get(key) if key in ("plant", "channel", "loop") else None
    return f" (in the {key} file {value_text(ref, 100)})" if isinstance(ref, str) else ""


def _budget(opts: Mapping[str, Any], key: str, default: float) -> float:
    if key not in opts:
        return default
    value = parse_number(opts[key], f"/options/{key}")
    if not 0 < value <= MAX_RUN_BUDGET_S:
        raise InvalidInput(f"/options/{key}", f"must be in (0, {MAX_RUN_BUDGET_S}] seconds")
    return float(value)


def parse_check(
    tree: Any, base: str | Path = ".", source: str = "<check>", allow_outside: Iterable[str | Path] = ()
) -> CheckSpec:
    """Validate a check file's tree; plant, channel and loop paths are relative to ``base``.

    Every path must lead (symlinks followed) to a regular file under ``base``
    or under one of the ``allow_outside`` directories; it is checked before
    the file is opened (see the module's docstring).

    Raises
    ------
    InvalidInput
        Naming the field of the check file (``/checks/0/requirements/margin``)
        and, for a plant or channel file, the field inside it (never its value).
    """
    roots = _Roots.of(Path(base), allow_outside)
    if not isinstance(tree, dict):
        raise InvalidInput("/", "a check file is an object with 'checks' (and optionally 'options')")
    unknown = sorted(set(tree) - CHECK_TOP_KEYS)
    if unknown:
        raise InvalidInput(f"/{unknown[0]}", f"unknown key; a check file has {sorted(CHECK_TOP_KEYS)}")
    opts = tree.get("options", {})
    if not isinstance(opts, dict):
        raise InvalidInput("/options", "expected an object")
    unknown = sorted(set(opts) - CHECK_OPTION_KEYS)
    if unknown:
        raise InvalidInput(
            json_pointer(("options", unknown[0])), f"unknown key; options has {sorted(CHECK_OPTION_KEYS)}"
        )
    checks = tree.get("checks")
    if not isinstance(checks, list) or not checks:
        raise InvalidInput("/checks", "expected a non-empty list of entries")
    if len(checks) > MAX_ENTRIES:
        raise InvalidInput("/checks", f"at most {MAX_ENTRIES} entries")
    entries = []
    names: set[str] = set()
    for i, entry in enumerate(checks):
        where = f"/checks/{i}"
        if not isinstance(entry, dict):
            raise InvalidInput(where, "expected an object with plant, requirements and (usually) channel")
        unknown = sorted(set(entry) - CHECK_ENTRY_KEYS)
        if unknown:
            raise InvalidInput(
                where + json_pointer((unknown[0],)), f"unknown key; an entry has {sorted(CHECK_ENTRY_KEYS)}"
            )
        if "loop" in entry:
            entries.append(_loop_entry(entry, roots, where, names))
            continue
        for need in ("plant", "requirements"):
            if need not in entry:
                raise InvalidInput(f"{where}/{need}", "required")
        system, plant_file = _part(entry["plant"], roots, f"{where}/plant", "plant", "system")
        if "trace" in entry or "level" in entry:
            channel = _trace_channel(entry, roots, where)
        elif "channel" in entry:
            channel, _ = _part(entry["channel"], roots, f"{where}/channel", "channel", "channel")
        elif "channel" in plant_file:
            channel = plant_file["channel"]
        else:
            raise InvalidInput(f"{where}/channel", "required (the plant file names no channel)")
        name = entry.get("name", f"{entry['plant']} / {entry.get('channel', entry.get('trace', 'its channel'))}")
        if not isinstance(name, str) or not name.strip():
            raise InvalidInput(f"{where}/name", "expected a non-empty string")
        if name in names:
            raise InvalidInput(
                f"{where}/name", f"the name {value_text(name, 100)} is used by an earlier entry; names must be unique"
            )
        names.add(name)
        request: dict[str, Any] = {"system": system, "channel": channel}
        if "options" in entry:
            request["options"] = entry["options"]
        elif isinstance(plant_file.get("options"), dict) and "channel" not in entry:
            request["options"] = plant_file["options"]
        try:
            with values_withheld():
                parse_request(resolved(request), DEFAULT_LIMITS.for_command("analyze"))  # each command checks its own
        except InvalidInput as exc:
            # the field inside the request maps to the file that holds it
            top = exc.field.split("/")[1] if exc.field.count("/") else ""
            owner = {"system": "plant", "channel": "channel" if "channel" in entry else "plant"}.get(top, "options")
            raise InvalidInput(f"{where}/{owner}", f"{exc.field}: {exc.rule}{_in_file(entry, owner)}") from None
        requirements = parse_requirements(entry["requirements"], f"{where}/requirements")
        looped = [r.key for r in requirements if r.command == "loop"]
        if looped:
            raise InvalidInput(
                f"{where}/requirements/{looped[0]}",
                "a loop requirement needs an entry naming a loop request file ('loop')",
            )
        if any(r.command in ("bounds", "simulate") for r in requirements) and not {"Q", "R"} <= set(system):
            keys = [r.key for r in requirements if r.command != "analyze"]
            raise InvalidInput(f"{where}/plant", f"the requirements {keys} need Q and R in the plant's system")
        entry_ = CheckEntry(name=name, request=request, requirements=requirements)
        with values_withheld():
            _validate_options(entry_, where)
        entries.append(entry_)
    return CheckSpec(
        entries=tuple(entries),
        time_budget_s=_budget(opts, "time_budget_s", DEFAULT_TIME_BUDGET_S),
        point_budget_s=_budget(opts, "point_budget_s", DEFAULT_POINT_BUDGET_S),
        source=source,
    )


def _loop_entry(entry: Mapping[str, Any], roots: _Roots, where: str, names: set[str]) -> CheckEntry:
    """An entry naming a loop request file: validated as ``kfio loop`` validates it, loop requirements only."""
    from ..loop import parse_loop_request

    for key in ("plant", "channel", "options"):
        if key in entry:
            raise InvalidInput(
                f"{where}/{key}", "an entry naming a loop file takes its plant, channels and options from it"
            )
    if "requirements" not in entry:
        raise InvalidInput(f"{where}/requirements", "required")
    request, _ = _part(entry["loop"], roots, f"{where}/loop", "loop", None)  # the whole file is the request
    name = entry.get("name", str(entry["loop"]))
    if not isinstance(name, str) or not name.strip():
        raise InvalidInput(f"{where}/name", "expected a non-empty string")
    if name in names:
        raise InvalidInput(
            f"{where}/name", f"the name {value_text(name, 100)} is used by an earlier entry; names must be unique"
        )
    names.add(name)
    try:
        with values_withheld():
            parse_loop_request(request)
    except InvalidInput as exc:
        raise InvalidInput(f"{where}/loop", f"{exc.field}: {exc.rule}{_in_file(entry, 'loop')}") from None
    requirements = parse_requirements(entry["requirements"], f"{where}/requirements")
    other = [r.key for r in requirements if r.command != "loop"]
    if other:
        raise InvalidInput(
            f"{where}/requirements/{other[0]}",
            "an entry naming a loop file takes the loop requirements only (loop_verdict, loop_cost_at_most, "
            "critical_sensor_arrival_probability_at_most, critical_actuator_arrival_probability_at_most)",
        )
    return CheckEntry(name=name, request=dict(request), requirements=requirements)


def load_check(path: str | Path, allow_outside: Iterable[str | Path] = ()) -> CheckSpec:
    """Read and validate the check file at ``path`` (JSON, or TOML by its suffix).

    The files it names must be regular files under its directory, or under one
    of the ``allow_outside`` directories (:func:`parse_check`).
    """
    path = Path(path)
    tree = load_tree(_read(path, "/", "check file"), path.name)
    return parse_check(tree, path.parent, str(path), allow_outside)


__all__ = ["CheckEntry", "CheckSpec", "load_check", "load_tree", "parse_check"]
