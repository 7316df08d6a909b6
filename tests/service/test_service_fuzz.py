"""Schemathesis fuzz of the checked-in OpenAPI document against a real server.

Bounded: a fixed number of examples per operation and generation mode
(derandomized, so a failure reproduces), a 1.5 s budget per request on the
server.  What must hold for every generated request, valid or not:

* never a 500; a 5xx is only 503/504 (budget, busy), or 501 while an
  analyzer module the endpoint needs is not in this build;
* the status code and content type are documented for the operation, and
  the body matches its documented schema.
"""

from __future__ import annotations

import importlib.util
import json
from collections.abc import Iterator

import pytest
import schemathesis
from hypothesis import HealthCheck, Phase, given, settings
from schemathesis import GenerationMode
from schemathesis.checks import content_type_conformance, response_schema_conformance, status_code_conformance

from support.live_server import OPENAPI_PATH as DEFAULT_PATH
from support.live_server import LiveServer

DOC = json.loads(DEFAULT_PATH.read_text(encoding="utf-8"))
SCHEMA = schemathesis.openapi.from_dict(DOC)
OPERATIONS = {op.label: op for op in (r.ok() for r in SCHEMA.get_all_operations())}
EXAMPLES = {GenerationMode.POSITIVE: 10, GenerationMode.NEGATIVE: 8}

#: Analyzer modules behind each endpoint (501 is acceptable only while one is missing).
NEEDS = {
    "POST /v1/bounds": ("kfio.mare._compute",),
    "POST /v1/plots/phase-transition": ("kfio.mare._compute", "kfio.mare._riccati"),
    "POST /v1/plots/region": ("kfio.mare._compute",),
}


@pytest.fixture(scope="module")
def server() -> Iterator[LiveServer]:
    with LiveServer(workers=2, env={"KFIO_TIME_BUDGET_S": "1.5"}) as live:
        yield live


def allowed_5xx(label: str) -> set[int]:
    missing = any(importlib.util.find_spec(m) is None for m in NEEDS.get(label, ()))
    return {503, 504, 501} if missing else {503, 504}


def fuzz(server: LiveServer, label: str, mode: GenerationMode) -> None:
    op = OPERATIONS[label]
    allowed = allowed_5xx(label)

    @settings(
        max_examples=EXAMPLES[mode],
        deadline=None,
        database=None,
        derandomize=True,
        phases=[Phase.explicit, Phase.generate],
        suppress_health_check=list(HealthCheck),
    )
    @given(case=op.as_strategy(generation_mode=mode))
    def check(case: schemathesis.Case) -> None:
        response = case.call(base_url=server.url, timeout=30)
        status = response.status_code
        assert status < 500 or status in allowed, f"{status} for {case.body!r}: {response.text[:300]}"
        case.validate_response(
            response, checks=[status_code_conformance, content_type_conformance, response_schema_conformance]
        )

    check()


@pytest.mark.parametrize("label", sorted(label for label in OPERATIONS if label.startswith("POST")))
@pytest.mark.parametrize("mode", list(EXAMPLES), ids=lambda m: m.value)
def test_fuzzed_requests_never_get_a_server_error(server: LiveServer, label: str, mode: GenerationMode) -> None:
    fuzz(server, label, mode)


@pytest.mark.parametrize("label", sorted(label for label in OPERATIONS if label.startswith("GET")))
def test_fuzzed_health_endpoints(server: LiveServer, label: str) -> None:
    fuzz(server, label, GenerationMode.POSITIVE)
