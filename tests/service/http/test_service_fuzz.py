"""Schemathesis fuzz of the checked-in OpenAPI document against a real server.

Bounded and seeded: a fixed number of examples per operation and generation
mode (derandomized, so a failure reproduces), a 1.5 s budget per request on
the server.  Every schemathesis check runs except ``max_response_time`` (no
test asserts a time).  What must hold for every generated request:

* never a 500; a 5xx is only 503/504 (budget, busy);
* the status code, content type and headers are documented for the
  operation, and the body matches its documented schema;
* data the schema refuses is refused (``negative_data_rejection``), a missing
  required header and an undocumented method are refused;
* data the schema accepts is answered 200, or 503/504 (budget), or 422 for a
  rule JSON Schema cannot state (symmetric or semidefinite Q/R, the names of
  the sensors, all Markov histories, the shape of a matrix, ...): the
  ``positive_data_acceptance`` check with those statuses allowed, and every
  such 422 must name its field and rule.

Figures of a run are in docs/service.md.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from collections.abc import Iterator

import pytest
import schemathesis
from hypothesis import HealthCheck, Phase, given, settings
from schemathesis import GenerationMode
from schemathesis.checks import (
    content_type_conformance,
    missing_required_header,
    negative_data_rejection,
    not_a_server_error,
    response_headers_conformance,
    response_schema_conformance,
    status_code_conformance,
    unsupported_method,
)

from support.live_server import OPENAPI_PATH as DEFAULT_PATH
from support.live_server import LiveServer

pytestmark = pytest.mark.slow  # a few minutes

DOC = json.loads(DEFAULT_PATH.read_text(encoding="utf-8"))
SCHEMA = schemathesis.openapi.from_dict(DOC)
OPERATIONS = {op.label: op for op in (r.ok() for r in SCHEMA.get_all_operations())}
EXAMPLES = {GenerationMode.POSITIVE: 10, GenerationMode.NEGATIVE: 8}

#: ``(operation, mode, status)`` -> requests sent; written to ``$KFIO_FUZZ_REPORT`` (JSON) if set.
TALLY: Counter[tuple[str, str, int]] = Counter()


@pytest.fixture(scope="module")
def server() -> Iterator[LiveServer]:
    with LiveServer(workers=2, env={"KFIO_TIME_BUDGET_S": "1.5"}) as live:
        yield live
    report = os.environ.get("KFIO_FUZZ_REPORT")
    if report:
        rows = [{"operation": op, "mode": mode, "status": st, "requests": n} for (op, mode, st), n in TALLY.items()]
        with open(report, "w", encoding="utf-8") as fh:
            json.dump(sorted(rows, key=lambda r: (r["operation"], r["mode"], r["status"])), fh, indent=1)


#: The only server errors allowed: busy or out of budget (1.5 s here).
ALLOWED_5XX = {503, 504}


def fuzz(server: LiveServer, label: str, mode: GenerationMode) -> None:
    op = OPERATIONS[label]

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
        TALLY[(label, mode.value, status)] += 1
        assert status < 500 or status in ALLOWED_5XX, f"{status} for {case.body!r}: {response.text[:300]}"
        checks = [
            status_code_conformance,
            content_type_conformance,
            response_headers_conformance,
            response_schema_conformance,
            missing_required_header,
            unsupported_method,
        ]
        if status not in ALLOWED_5XX:
            checks.append(not_a_server_error)
        if mode is GenerationMode.NEGATIVE:
            if status == 413:  # a generated body over the 1 MiB limit: refused, just not by schemathesis' list
                assert response.json()["type"].endswith("too-large")
            else:
                checks.append(negative_data_rejection)
        elif label.startswith("POST"):
            # positive data: accepted (jobs and sweeps: queued, or 429 when the queue is full), out of budget,
            # or refused for a rule the schema cannot state
            accepted = {202, 429} if label.startswith(("POST /v1/jobs/", "POST /v1/sweeps")) else {200}
            assert status in accepted | {422} | ALLOWED_5XX, (
                f"{status} for valid-by-schema {case.body!r}: {response.text[:300]}"
            )
            if status == 422:
                problem = response.json()
                assert problem.get("field") is not None or problem["type"].endswith("memory-exceeded"), problem
        case.validate_response(response, checks=checks)

    check()


@pytest.mark.parametrize("label", sorted(label for label in OPERATIONS if label.startswith("POST")))
@pytest.mark.parametrize("mode", list(EXAMPLES), ids=lambda m: m.value)
def test_fuzzed_requests_never_get_a_server_error(server: LiveServer, label: str, mode: GenerationMode) -> None:
    fuzz(server, label, mode)


@pytest.mark.parametrize("label", sorted(label for label in OPERATIONS if label.startswith("GET")))
def test_fuzzed_health_endpoints(server: LiveServer, label: str) -> None:
    fuzz(server, label, GenerationMode.POSITIVE)
