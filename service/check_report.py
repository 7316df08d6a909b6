"""The views of a ``kfio check`` result: a terminal table, JUnit XML, Markdown.

JUnit XML follows the Ant/Jenkins schema that CI systems read: one
``<testsuite>`` per entry (plant and channel), one ``<testcase>`` per
requirement, a ``<failure>`` whose message is "measured X, required Y" for a
requirement that does not hold and an ``<error>`` for one that could not be
judged.  Markdown is a table for a CI step summary (``$GITHUB_STEP_SUMMARY``).

Every number reads as kfio's summaries do (:func:`kfio._numbers.readable_measure`): a decimal,
and the exact form beside it when it is short; a long one (a float plant's
``1 - 1/CRootOf(15625000...)``) is its decimal and what kind of number it is.  No cell is wider
than its cap (:data:`WIDTHS`), so a table line stays under :data:`LINE_CAP` characters; the
exact texts are in ``--json``.
"""

from __future__ import annotations

import socket
import xml.etree.ElementTree as ET
from datetime import UTC, datetime
from typing import TYPE_CHECKING

from kfio._numbers import clip, readable_measure
from kfio.model import escaped

if TYPE_CHECKING:
    from kfio.check import CheckResult, Outcome

_MARK = {"pass": "PASS", "fail": "FAIL", "error": "ERROR"}

#: The widest cell of each column of :func:`table` (a requirement key is at most 46 characters); the
#: entry column gives way further when a line would be wider than :data:`LINE_CAP`.
WIDTHS = {"status": 6, "entry": 48, "requirement": 46, "measured": 36, "required": 36}
#: The widest line of :func:`table`.
LINE_CAP = 160


def measured_text(o: Outcome) -> str:
    """The measured value as people read it (or the error), at most ``WIDTHS["measured"]`` characters."""
    text = f"{o.error_kind}: {o.detail}" if o.status == "error" else readable_measure(o.measured)
    return clip(text, WIDTHS["measured"])


def required_text(o: Outcome) -> str:
    """The requirement's limit as people read it, at most ``WIDTHS["required"]`` characters."""
    return clip(readable_measure(o.required), WIDTHS["required"])


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
        return f"{o.error_kind}: {o.detail} (required {readable_measure(o.required)})"
    return f"measured {readable_measure(o.measured)}, required {readable_measure(o.required)}"


def table(result: CheckResult) -> str:
    """A fixed-width table: status, entry, requirement, measured, required; the headline below.

    Cells are cut to :data:`WIDTHS` (ending in ``...``), so no line is wider than :data:`LINE_CAP`.
    """
    rows = [("status", "entry", "requirement", "measured", "required")]
    for o in result.outcomes:
        rows.append(
            (_MARK[o.status], o.entry, clip(o.requirement, WIDTHS["requirement"]), measured_text(o), required_text(o))
        )
    others = sum(max(len(r[i]) for r in rows) for i in (0, 2, 3, 4)) + 2 * 4
    entry_width = max(16, min(WIDTHS["entry"], LINE_CAP - others))
    rows = [(r[0], clip(r[1], entry_width), *r[2:]) for r in rows]
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
            "\n".join(f"{o.requirement}: {o.status}: {message(o)}" for o in outcomes)
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
        lines.append(
            f"| {icon[o.status]} | {_md(clip(o.entry, WIDTHS['entry']))} | `{o.requirement}` "
            f"| {_md(measured_text(o))} | {_md(required_text(o))} |"
        )
    return "\n".join(lines) + "\n"


__all__ = [
    "LINE_CAP",
    "WIDTHS",
    "headline",
    "junit_xml",
    "markdown",
    "measured_text",
    "message",
    "required_text",
    "table",
]
