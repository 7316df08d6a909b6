"""Every command is wired on every surface it belongs to, and its absence from the others is deliberate.

The commands are the CLI's sub-commands (the modules of ``kfio.service.commands``). For each one this
test asks: its report has a JSON view (``kfio._json``), the service has its worker job and its job kind,
its HTTP routes (synchronous and ``/v1/jobs/...``) are in the OpenAPI document, its request and report
have a JSON Schema file and an OpenAPI component, ``kfio check`` can judge it and ``kfio sweep`` can sweep
it. Where a command is absent from a surface on purpose, the exemption below says why; a new command
fails here until it is wired or exempted (see "Add a command" in docs/contributing.md).
"""

from __future__ import annotations

import json
import pkgutil

import pytest

from kfio._json import view_of
from kfio.check import COMMAND_OF
from kfio.service import commands
from kfio.service.jobs import JOBS
from kfio.service.jobstore import BUILTIN_KINDS
from kfio.sweep import FIELDS
from kfio.sweep._spec import COMMANDS as SWEEP_COMMANDS

from support.paths import ROOT

#: Sub-commands that are not analyses: they have no report, so no surface below applies.
NOT_ANALYSES = {"serve": "runs the HTTP service itself"}

COMMANDS = sorted(m.name for m in pkgutil.iter_modules(commands.__path__) if m.name not in NOT_ANALYSES)


def _report_classes() -> dict[str, type]:
    from kfio.check import CheckResult
    from kfio.fit import FitReport
    from kfio.loop import LoopReport
    from kfio.riccati_bounds import BoundsReport
    from kfio.simulation import SimulationReport
    from kfio.stability import StabilityReport
    from kfio.sweep import SweepResult

    return {
        "analyze": StabilityReport,
        "bounds": BoundsReport,
        "simulate": SimulationReport,
        "loop": LoopReport,
        "fit": FitReport,
        "sweep": SweepResult,
        "check": CheckResult,
    }


#: Commands without an HTTP surface (no route, no worker job, no job kind), and why.
NO_HTTP = {
    "check": "a check file names plant, channel and trace files on the caller's disk: it runs where they are "
    "(CI), and each entry's request has its own endpoint",
}
#: The HTTP routes of a command when they are not ``POST /v1/<command>`` and ``POST /v1/jobs/<command>``.
ROUTES = {"sweep": {"/v1/sweeps"}}  # a sweep is always a job: one route queues it, the job routes serve it
#: The JSON Schema files of a command's request and report when they are not ``<command>`` and
#: ``<command>-report``; ``None``: no such document, for the reason in :data:`NO_DOCUMENT`.
SCHEMA_FILES: dict[str, tuple[str, str | None]] = {
    "analyze": ("request", "analyze-report"),
    "bounds": ("request", "bounds-report"),
    "simulate": ("request", "simulate-report"),
    "sweep": ("sweep", None),
}
NO_DOCUMENT = {"sweep": "a sweep's result is a table of rows (JSON Lines, CSV, Parquet), described by its columns"}
#: Commands whose request and report schemas are not OpenAPI components, and why.
NOT_IN_OPENAPI = {
    "sweep": "the /v1/sweeps body is described inline, and the result is a table",
    "check": NO_HTTP["check"],
}
#: Commands that ``kfio check`` cannot judge, and why.
NOT_CHECKED = {
    "fit": "a check entry names its trace and is judged by the requirements on the fitted channel's verdicts",
    "sweep": "a sweep is many requests; a check file lists the requests to judge as entries",
    "check": "a check judges the other commands' reports",
}
#: Commands that ``kfio sweep`` cannot sweep, and why.
NOT_SWEPT = {
    "fit": "its input is a packet trace, not a request with exact values to vary",
    "sweep": "axes combine in one sweep: a sweep of sweeps is a larger sweep",
    "check": "a check file is a fixed list of entries judged together",
}
EXEMPTIONS = (NOT_ANALYSES, NO_HTTP, ROUTES, SCHEMA_FILES, NO_DOCUMENT, NOT_IN_OPENAPI, NOT_CHECKED, NOT_SWEPT)


def _documents() -> dict[str, tuple[str, str]]:
    """The schema files' table (``kfio.service.schema_files.DOCUMENTS``)."""
    from kfio.service.schema_files import DOCUMENTS

    return DOCUMENTS


def _openapi() -> dict:
    return json.loads((ROOT / "openapi" / "openapi.json").read_text())


def test_the_commands_are_found() -> None:
    assert {"analyze", "bounds", "simulate", "loop", "fit", "check", "sweep"} <= set(COMMANDS)


def test_every_exemption_names_a_command() -> None:
    """An exemption left behind by a removed or renamed command fails too."""
    for table in EXEMPTIONS:
        assert set(table) <= set(COMMANDS) | set(NOT_ANALYSES), table


@pytest.mark.parametrize("command", COMMANDS)
def test_its_report_has_a_json_view(command: str) -> None:
    classes = _report_classes()
    assert command in classes, f"name the report class of {command!r} in _report_classes"
    assert view_of(classes[command]) is not None


@pytest.mark.parametrize("command", COMMANDS)
def test_its_worker_job_and_job_kind(command: str) -> None:
    kinds = {k.name for k in BUILTIN_KINDS}
    if command in NO_HTTP:
        assert command not in JOBS and command not in kinds
        return
    assert command in JOBS, f"service/jobs.py JOBS has no {command!r}"
    assert command in kinds, f"service/jobstore.py BUILTIN_KINDS has no {command!r}"


@pytest.mark.parametrize("command", COMMANDS)
def test_its_http_routes(command: str) -> None:
    paths = set(_openapi()["paths"])
    if command in NO_HTTP:
        assert not {p for p in paths if p.rstrip("/").endswith("/" + command)}
        return
    expected = ROUTES.get(command, {f"/v1/{command}", f"/v1/jobs/{command}"})
    assert expected <= paths
    for path in expected:
        assert "post" in _openapi()["paths"][path]


@pytest.mark.parametrize("command", COMMANDS)
def test_its_json_schemas(command: str) -> None:
    request, report = SCHEMA_FILES.get(command, (command, f"{command}-report"))
    assert (report is None) == (command in NO_DOCUMENT)
    components = _openapi()["components"]["schemas"]
    documents = _documents()
    for name in (request, report):
        if name is None:
            continue
        assert name in documents, f"service/schema_files.py DOCUMENTS has no {name!r}"
        assert (ROOT / "service" / "schemas" / f"{name}.json").is_file()
        if command not in NOT_IN_OPENAPI:
            component = documents[name][0]
            assert component in components, f"OpenAPI has no component {component!r} for {command!r}"


@pytest.mark.parametrize("command", COMMANDS)
def test_check_can_judge_it(command: str) -> None:
    judged = set(COMMAND_OF.values())
    assert (command in judged) != (command in NOT_CHECKED)


@pytest.mark.parametrize("command", COMMANDS)
def test_sweep_can_sweep_it(command: str) -> None:
    swept = command in FIELDS
    assert swept != (command in NOT_SWEPT)
    assert swept == (command in SWEEP_COMMANDS)


def test_the_surfaces_name_only_commands() -> None:
    """check and sweep know no command the CLI lacks, and the sweep route offers exactly the swept ones."""
    assert set(COMMAND_OF.values()) <= set(COMMANDS)
    assert set(FIELDS) <= set(COMMANDS)
    body = _openapi()["paths"]["/v1/sweeps"]["post"]["requestBody"]["content"]["application/json"]["schema"]
    assert set(body["properties"]["command"]["enum"]) == set(FIELDS)
