"""The JUnit XML of ``kfio check`` validates against the Jenkins/Ant JUnit schema (tests/support/junit.xsd)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import xmlschema  # the test extra: a missing validator fails here, it does not skip

XSD = Path(__file__).resolve().parents[1] / "support" / "junit.xsd"


@pytest.fixture(scope="module")
def schema():
    return xmlschema.XMLSchema(str(XSD))


@pytest.mark.parametrize("name", ["kfio-check.json", "kfio-check-failing.json"])
def test_junit_validates(example_runs, schema, name):
    text = example_runs[name]["junit"]
    schema.validate(text)
    root = ET.fromstring(text)
    cases = root.findall("testsuite/testcase")
    assert int(root.get("tests")) == len(cases) > 0
    assert int(root.get("failures")) == len(root.findall("testsuite/testcase/failure"))
    for suite in root.findall("testsuite"):
        assert int(suite.get("tests")) == len(suite.findall("testcase"))


def test_the_schema_rejects_what_ci_would(schema, example_runs):
    # the schema is not vacuous: a negative count, a testcase without a name, an unknown child all fail
    text = example_runs["kfio-check-failing.json"]["junit"]
    assert schema.is_valid(text) and 'failures="1"' in text and '<testcase name="verdict"' in text
    assert not schema.is_valid(text.replace('failures="1"', 'failures="-1"', 1))
    assert not schema.is_valid(text.replace('<testcase name="verdict"', "<testcase", 1))
    assert not schema.is_valid(text.replace("<properties>", "<properties><bogus/>", 1))


def test_one_testcase_per_requirement_failure_text_measured_vs_required(example_runs):
    root = ET.fromstring(example_runs["kfio-check-failing.json"]["junit"])
    failures = {
        (case.get("classname"), case.get("name")): case.find("failure")
        for case in root.iter("testcase")
        if case.find("failure") is not None
    }
    assert len(failures) == 4
    vbar = failures[("two-state plant on the radio link", "trace_V_bar_at_most")]
    assert vbar.get("message").startswith("measured 8.6") and vbar.get("message").endswith("required <= 8")
    assert vbar.get("type") == "RequirementNotMet"
    verdict = failures[("two-state plant on the bursty link", "verdict")]
    assert verdict.get("message") == "measured unstable, required = stable"
    passing = ET.fromstring(example_runs["kfio-check.json"]["junit"])
    assert passing.find(".//failure") is None and passing.find(".//error") is None
