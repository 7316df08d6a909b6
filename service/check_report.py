"""The views of a ``kfio check`` result: a terminal table, JUnit XML, Markdown.

JUnit XML follows the Ant/Jenkins schema that CI systems read: one
``<testsuite>`` per entry (plant and channel), one ``<testcase>`` per
requirement, a ``<failure>`` whose message is "measured X, required Y" for a
requirement that does not hold and an ``<error>`` for one that could not be
judged.  Markdown is a table for a CI step summary (``$GITHUB_STEP_SUMMARY``).
"""

from __future__ import annotations

import socket
import xml.etree.ElementTree as ET
from datetime import UTC, datetime
from typing import TYPE_CHECKING

from kfio.model import escaped

if TYPE_CHECKING:
    from kfio.check import CheckResult, Outcome

_MARK = {"pass": "PASS", "fail": "FAIL", "error": "ERROR"}


def headline(result: CheckResult) -> str:
    """One line: how many requirements hold, fail, could not be judged."""
    d = result.to_dict()
    word = {"pass": "all requirements hold", "fail": "requirements FAIL", "budget": "the budget ran out"}[result.status]
    return (
        f"kfio check: {word}: {d['passed']} passed, {d['failed']} failed, {d['errors']} errors "
        f"of {d['requirements']} requirements ({result.seconds:.2f} s, {result.workers} workers)"
    )


def message(o: Outcome) -> str:
    """The failure text of one outcome: measured vs required."""
    if o.status == "error":
        return f"{o.error_kind}: {o.detail} (required {o.required})"
    return f"measured {o.measured}, required {o.required}"


def table(result: CheckResult) -> str:
    """A fixed-width table: status, entry, requirement, measured, required; the headline below."""
    rows = [("status", "entry", "requirement", "measured", "required")]
    for o in result.outcomes:
        measured = o.measured if o.status != "error" else f"{o.error_kind}: {o.detail}"
        rows.append((_MARK[o.status], o.entry, o.requirement, measured, o.required))
    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    lines = ["  ".join(r[i].ljust(widths[i]) for i in range(4)) + "  " + r[4] for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths) + "  " + "-" * len("required"))
    return escaped("\n".join(lines) + "\n\n" + headline(result))


def _seconds(x: float) -> str:
    return f"{x:.3f}"


def junit_xml(result: CheckResult) -> str:
    """JUnit XML text: ``<testsuites>`` with one ``<testsuite>`` per entry, one ``<testcase>`` per requirement."""
    stamp = datetime.now(UTC).replace(microsecond=0, tzinfo=None).isoformat()
    host = socket.gethostname() or "localhost"
    d = result.to_dict()
    root = ET.Element(
        "testsuites",
        name="kfio check",
        tests=str(d["requirements"]),
        failures=str(d["failed"]),
        errors=str(d["errors"]),
        time=_seconds(result.seconds),
    )
    entries: dict[str, list[Outcome]] = {}
    for o in result.outcomes:
        entries.setdefault(o.entry, []).append(o)
    for i, (entry, outcomes) in enumerate(entries.items()):
        suite = ET.SubElement(
            root,
            "testsuite",
            name=escaped(entry),
            id=str(i),
            package="kfio.check",
            tests=str(len(outcomes)),
            failures=str(sum(o.status == "fail" for o in outcomes)),
            errors=str(sum(o.status == "error" for o in outcomes)),
            skipped="0",
            time=_seconds(sum(o.seconds for o in outcomes)),
            timestamp=stamp,
            hostname=host,
        )
        props = ET.SubElement(suite, "properties")
        ET.SubElement(props, "property", name="source", value=escaped(result.source))
        for o in outcomes:
            case = ET.SubElement(
                suite, "testcase", name=o.requirement, classname=escaped(entry), time=_seconds(o.seconds)
            )
            if o.status == "fail":
                node = ET.SubElement(case, "failure", message=escaped(message(o)), type="RequirementNotMet")
                node.text = escaped(f"{entry}: {o.requirement}: {message(o)}\n{o.detail}")
            elif o.status == "error":
                node = ET.SubElement(case, "error", message=escaped(message(o)), type=o.error_kind or "error")
                node.text = escaped(f"{entry}: {o.requirement}: {message(o)}")
        ET.SubElement(suite, "system-out").text = escaped(
            "\n".join(f"{o.requirement}: {o.status}: measured {o.measured}, required {o.required}" for o in outcomes)
        )
        ET.SubElement(suite, "system-err").text = ""
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _md(text: str) -> str:
    return escaped(text).replace("|", "\\|").replace("\n", " ")


def markdown(result: CheckResult) -> str:
    """A Markdown summary: the headline, then one table row per requirement (failures first)."""
    icon = {"pass": "pass", "fail": "**FAIL**", "error": "**ERROR**"}
    order = {"fail": 0, "error": 1, "pass": 2}
    lines = [
        f"### kfio check: `{_md(result.source)}`",
        "",
        headline(result).removeprefix("kfio check: ").capitalize() + ".",
        "",
        "| status | entry | requirement | measured | required |",
        "|---|---|---|---|---|",
    ]
    for o in sorted(result.outcomes, key=lambda o: order[o.status]):
        measured = o.measured if o.status != "error" else f"{o.error_kind}: {o.detail}"
        lines.append(f"| {icon[o.status]} | {_md(o.entry)} | `{o.requirement}` | {_md(measured)} | {_md(o.required)} |")
    return "\n".join(lines) + "\n"


__all__ = ["headline", "junit_xml", "markdown", "message", "table"]
