"""One number format on every surface people and pipelines read (kfio._numbers).

The reader of kfio's exact texts is checked against SymPy's own parser (tests may use it; the
library may not), the format's rules on hand-made cases, and every surface is rendered for float
plants (a ``control.c2d`` pendulum, a float loop): no ``CRootOf``, no run of 40 digits, no line
wider than the cap.
"""

from __future__ import annotations

import json
import random
import re
import shutil
from fractions import Fraction
from pathlib import Path

import pytest
import sympy

from kfio._numbers import EXACT_CAP, clip, exact_value, looks_like_float_data, number_text, readable_measure, show
from kfio.service.cli import main

ROOT = Path(__file__).resolve().parents[1]
PENDULUM = ROOT / "examples" / "pendulum_c2d.json"
LINE_CAP = 160
LONG_DIGITS = re.compile(r"\d{40}")

#: A loop whose plant and weights are float data (two states, a sampled pendulum's first block).
FLOAT_LOOP = {
    "system": {
        "A": [[1.0004897194771216, 0.009976507175556216], [0.09786953539220648, 0.995451876726684]],
        "B": [[0.00004958916265954385], [0.00987732885023713]],
        "C": [[1, 0]],
        "Q": [[1, 0], [0, 1]],
        "R": [[0.01]],
    },
    "channel": {"model": "bernoulli", "arrival_probability": 0.8},
    "actuator_channel": {"model": "bernoulli", "arrival_probability": 0.9},
    "controller": {"lqg": {"W": [[1, 0], [0, 1]], "U": [[0.5]]}},
    "cost": {"W": [[1, 0], [0, 1]], "U": [[0.5]]},
    "options": {"loop": {"protocol": "tcp", "on_loss": "zero"}},
}


# ---------------------------------------------------------------- the reader against SymPy


TEXTS = [
    "9/16",
    "-75/152",
    "1 - 1/sqrt(2)",
    "7/8 - sqrt(7009)/200",
    "(3 + sqrt(5))/2",
    "2**(-1/3)",
    "1 - 1/CRootOf(x**3 - 3*x - 1, 2)**2",
    "1 - 1/CRootOf(15625*x**3 - 31311*x + 1, 1)",
    "-CRootOf(x**4 - 10*x**2 + 1, 0) + 1/2",
    "log(2)/log(9/4)",
    "log(2)/(3*log(5/4))",
    "1/2 + sqrt(3)*I/2",
    "0.25 + 1/8",
]


@pytest.mark.parametrize("text", TEXTS)
def test_reader_agrees_with_sympy(text: str) -> None:
    expected = sympy.sympify(text, rational=True)  # the oracle: SymPy's parser, never used by kfio itself
    got = exact_value(text)
    assert complex(got.value) == pytest.approx(complex(sympy.N(expected, 20)), rel=1e-12, abs=1e-15)
    if expected.has(sympy.log):
        assert got.degree is None
    else:
        x = sympy.Symbol("x")
        assert got.degree == sympy.minimal_polynomial(expected, x, polys=True).degree()


def test_reader_on_a_float_plants_own_texts() -> None:
    """The critical probability and tail exponent kfio writes for the pendulum: read and evaluated alike."""
    import kfio

    report = kfio.analyze(kfio.load_request(PENDULUM.read_text())).to_dict()
    text = report["critical_arrival_probability_exact"]
    assert "CRootOf" in text and len(text) > 200
    parsed = exact_value(text)
    assert parsed.value == pytest.approx(report["critical_arrival_probability"], rel=1e-12)
    assert parsed.value == pytest.approx(float(sympy.N(sympy.sympify(text), 20)), rel=1e-13)
    assert parsed.degree == 3
    kappa = report["tail"]["kappa_exact"]
    assert exact_value(kappa).value == pytest.approx(report["tail"]["kappa"], rel=1e-10)


@pytest.mark.parametrize(
    "text",
    [
        "__import__('os')",
        "x + 1",
        "sqrt(x)",
        "CRootOf(x**2 - 2, 0, 1)",
        "1 +",
        "2**99999",
        "a.b",
        "CRootOf(sqrt(x), 0)",
    ],
)
def test_reader_refuses_what_is_not_an_exact_number(text: str) -> None:
    with pytest.raises((ValueError, TypeError)):
        exact_value(text)
    assert show(text, 0.5).decimal == "0.5"  # the format still shows the decimal it was given


# ---------------------------------------------------------------- the format's rules


def test_short_exact_forms_stand_beside_the_decimal() -> None:
    assert number_text("9/16") == "0.5625 = 9/16"
    assert number_text("75/152", 75 / 152) == "0.493421 = 75/152"
    assert number_text("12") == "12"
    assert number_text(None, 0.123456789) == "0.123457"
    assert number_text("7/8 - sqrt(7009)/200") == "0.456401 = 7/8 - sqrt(7009)/200"


def test_long_forms_say_what_they_are() -> None:
    r = sympy.CRootOf(sympy.Symbol("x") ** 3 - 3 * sympy.Symbol("x") - 1, 2)
    text = str(1 - 1 / r**2 + 1 / r + sympy.Rational(1, 7))
    assert len(text) > EXACT_CAP
    assert number_text(text) == f"{float(1 - 1 / r**2 + 1 / r + sympy.Rational(1, 7)):.6g} (algebraic, degree 3)"
    big = "12345678901234567890123456789/98765432109876543210987654321"
    assert number_text(big) == f"{float(Fraction(big)):.6g} (29-digit fraction)"
    floaty = "70400000000000000000000000000/230395516585597167079575641111"
    assert looks_like_float_data(floaty) and not looks_like_float_data(big)
    assert number_text(floaty) == "0.305562 (from float data)"
    assert number_text(big, from_float=True) == f"{float(Fraction(big)):.6g} (from float data)"
    assert show(floaty).exact_column == "from float data" and show("9/16").exact_column == "9/16"


def test_measured_texts_of_check_and_clip() -> None:
    assert readable_measure("worst rate 9/16") == "worst rate 0.5625 = 9/16"
    assert readable_measure("<= 2/5") == "<= 0.4 = 2/5"
    assert readable_measure("unstable") == "unstable"
    assert readable_measure("0.02 (95% CI [0.01, 0.03], 4000 samples)") == "0.02 (95% CI [0.01, 0.03], 4000 samples)"
    assert clip("abcdefghij", 10) == "abcdefghij" and clip("abcdefghijk", 10) == "abcdefg..."


# ---------------------------------------------------------------- every surface, float plants


def _clean(text: str, cap: int | None = LINE_CAP) -> None:
    assert "CRootOf" not in text
    assert not LONG_DIGITS.search(text), LONG_DIGITS.search(text)
    wide = [line for line in text.splitlines() if cap is not None and len(line) > cap]
    assert wide == [], wide


@pytest.mark.slow
@pytest.mark.parametrize("command", ["analyze", "bounds"])
def test_cli_summaries_of_a_float_plant(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    code = main([command, str(PENDULUM)])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "0.0544" in out  # the critical arrival probability's decimal is there
    _clean(out + err)


#: A plant with rational entries whose critical arrival probability is a long algebraic number:
#: ``1 - 1/alpha^2`` for the largest root of ``x^3 - 3x - 1`` (the companion matrix's), degree 3.
CUBIC = {
    "system": {"A": [[0, 1, 0], [0, 0, 1], [1, 3, 0]], "C": [[1, 0, 0]]},
    "channel": {"model": "bernoulli", "arrival_probability": "9/10"},
}
_CRITICAL_LINE = re.compile(r"critical arrival probability: (\S+)(?: = (\S+)| \(([^()]+)\))?")


@pytest.mark.slow
@pytest.mark.parametrize("plant", ["pendulum_c2d", "cubic"])
def test_analyze_summary_uses_the_one_format(plant: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``kfio analyze``: the decimal first, the kind of a long exact number, never its text or ``(exact: ...)``."""
    path = PENDULUM if plant == "pendulum_c2d" else tmp_path / "cubic.json"
    if plant == "cubic":
        path.write_text(json.dumps(CUBIC))
    assert main(["analyze", str(path)]) == 0
    out = capsys.readouterr().out
    assert main(["analyze", "--json", str(path)]) == 0
    report = json.loads(capsys.readouterr().out)
    _clean(out)
    assert "(exact: " not in out and "exact form" not in out and "JSON field" not in out
    exact = report["critical_arrival_probability_exact"]
    assert len(exact) > EXACT_CAP and "CRootOf" in exact  # long in the JSON, whole

    (line,) = [x for x in out.splitlines() if x.startswith("critical arrival probability: ")]
    m = _CRITICAL_LINE.fullmatch(line)
    assert m and m.group(2) is None, line  # no exact text beside the decimal: it is too long
    expr = sympy.sympify(exact)  # SymPy's own reading of the JSON text (the library never sympifies)
    assert float(m.group(1)) == pytest.approx(float(sympy.N(expr, 20)), rel=1e-5)
    assert m.group(1) == f"{report['critical_arrival_probability']:.6g}"
    degree = sympy.degree(sympy.minimal_polynomial(expr, sympy.Symbol("x")))
    from_float = ", from float data" if plant == "pendulum_c2d" else ""
    assert m.group(3) == f"algebraic, degree {degree}{from_float}" and degree == 3

    (tail,) = [x for x in out.splitlines() if x.startswith("tail exponent kappa = ")]
    kappa = tail.removeprefix("tail exponent kappa = ").split(":")[0]
    assert float(kappa.split(" ")[0]) == pytest.approx(report["tail"]["kappa"], rel=1e-5)
    assert kappa == number_text(report["tail"]["kappa_exact"], report["tail"]["kappa"])


@pytest.mark.slow
def test_trace_region_label_of_a_float_plant(monkeypatch: pytest.MonkeyPatch) -> None:
    """The trace-region plot marks ``lambda_c`` in the one format, not with the JSON's exact text."""
    from matplotlib.axes import Axes

    from kfio import Budget, analyze, load_request
    from kfio.fit._requests import DEFAULT_LIMITS
    from kfio.service.fit_plot import trace_region

    plant = json.loads(PENDULUM.read_text())
    exact = analyze(load_request(json.dumps(plant)))
    draws = random.Random(1)  # independent arrivals: BIC picks a Bernoulli model, drawn on one axis
    plant["channel"] = {"model": "trace", "arrivals": [int(draws.random() < 0.3) for _ in range(500)]}
    labels: list[str] = []
    annotate = Axes.annotate

    def spy(self: Axes, text: str, *args: object, **kwargs: object) -> object:
        labels.append(text)
        return annotate(self, text, *args, **kwargs)

    monkeypatch.setattr(Axes, "annotate", spy)
    trace_region(json.dumps(plant).encode(), DEFAULT_LIMITS, Budget(60), {})
    (label,) = [t for t in labels if t.startswith("lambda_c = ")]
    _clean(label)
    shown = show(exact.critical_arrival_probability_exact, exact.critical_arrival_probability)
    assert label == f"lambda_c = {shown.text}" and label.startswith(f"lambda_c = {shown.decimal} (")


@pytest.mark.slow
def test_loop_summary_of_a_float_loop(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "loop.json"
    path.write_text(json.dumps(FLOAT_LOOP))
    code = main(["loop", str(path)])
    out, err = capsys.readouterr()
    assert code == 0, err
    _clean(out + err)
    main(["loop", "--json", str(path)])
    report = json.loads(capsys.readouterr().out)
    for key in ("sensor", "actuator"):
        exact = report[f"critical_{key}_arrival_probability_exact"]
        assert len(exact) > 200  # long in the JSON, whole
        line = next(x for x in out.splitlines() if x.startswith(f"critical {key} arrival probability: "))
        shown = show(exact, report[f"critical_{key}_arrival_probability"])
        # the decimal first, then what the long exact form is (the loop summary adds its degree when known)
        assert line.split(": ", 1)[1].startswith(f"{shown.decimal} (") and shown.note in line
        decimal = line.split(": ", 1)[1].split(" ")[0]
        assert float(decimal) == pytest.approx(float(sympy.N(sympy.sympify(exact), 20)), rel=1e-5)


@pytest.mark.slow
def test_check_table_markdown_and_junit_of_a_float_plant(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    shutil.copy(PENDULUM, tmp_path / "pendulum.json")
    check = {
        "checks": [
            {
                "name": "a pendulum sampled by control.c2d with a long descriptive entry name",
                "plant": "pendulum.json",
                "requirements": {
                    "verdict": "stable",
                    "margin": "1/100",
                    "critical_arrival_probability_at_most": 0.05,
                    "trace_V_bar_at_most": 1000,
                    "tail_exponent_above": 1,
                },
            }
        ]
    }
    (tmp_path / "check.json").write_text(json.dumps(check))
    md, xml = tmp_path / "summary.md", tmp_path / "report.xml"
    code = main(["check", str(tmp_path / "check.json"), "--workers", "1", "--markdown", str(md), "--junit", str(xml)])
    out, err = capsys.readouterr()
    assert code == 1, err  # 0.0544 > 0.05: the critical probability fails, and says so readably
    _clean(out)
    _clean(md.read_text(), cap=200)  # Markdown rows carry their pipes and backticks
    _clean(xml.read_text(), cap=None)  # XML attributes are one line per element: no width to keep
    row = next(line for line in out.splitlines() if "critical_arrival_probability_at_most" in line)
    assert row.startswith("FAIL") and "0.0544201" in row and "<= 0.05 = 1/20" in row
    assert "failure" in xml.read_text() and "measured 0.0544201" in xml.read_text()
    main(["check", str(tmp_path / "check.json"), "--workers", "1", "--json"])
    data = json.loads(capsys.readouterr().out)
    whole = [o["measured"] for o in data["outcomes"] if o["requirement"] == "critical_arrival_probability_at_most"]
    assert "CRootOf" in whole[0]  # the pipeline's JSON keeps the exact text


@pytest.mark.slow
def test_reprs_of_reports_of_float_data() -> None:
    """A report's repr is a few telling fields in the same format, never every field of the dataclass."""
    import kfio
    from kfio.loop import analyze_loop, parse_loop_request
    from kfio.sweep import load_sweep, run_sweep

    loop = analyze_loop(parse_loop_request(json.loads(json.dumps(FLOAT_LOOP))))
    assert len(str(loop.stationary_cost)) > 200  # the exact cost is a long fraction
    analysis = kfio.analyze(kfio.load_request(PENDULUM.read_text()))
    sweep = {
        "command": "analyze",
        "base": json.loads(PENDULUM.read_text()),
        "axes": [{"pointer": "/channel/arrival_probability", "values": ["1/2", "9/10"]}],
    }
    swept = run_sweep(load_sweep(json.dumps(sweep)), engine="serial")
    for report in (loop, analysis, swept):
        text = repr(report)
        _clean(text, cap=None)  # a repr is one line: as long as its fields, each short
        assert text.startswith(type(report).__name__ + "(")
    assert len(repr(loop)) < 160 and len(repr(swept)) < 160  # before: every field, 11,000 characters
    assert repr(loop).startswith("LoopReport(verdict='stable', spectral_radius=0.97824, cost=")
    assert "points=2" in repr(swept)


@pytest.mark.slow
def test_sweep_csv_of_a_float_plant_names_the_kind_jsonl_keeps_the_text(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import csv

    from kfio.sweep._table import CSV_EXACT_CAP

    sweep = {
        "command": "analyze",
        "base": json.loads(PENDULUM.read_text()),
        "axes": [{"pointer": "/channel/arrival_probability", "values": ["1/2", "9/10"]}],
    }
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(sweep))
    table, lines = tmp_path / "t.csv", tmp_path / "t.jsonl"
    assert main(["sweep", str(path), "--quiet", "--serial", "--out", str(table)]) == 0
    assert main(["sweep", str(path), "--quiet", "--serial", "--out", str(lines)]) == 0
    capsys.readouterr()
    _clean(table.read_text())
    rows = list(csv.DictReader(table.open()))
    whole = [json.loads(x) for x in lines.read_text().splitlines()]
    for row, full in zip(rows, whole):
        assert (
            len(full["critical_arrival_probability_exact"]) > CSV_EXACT_CAP
            and "CRootOf" in full["critical_arrival_probability_exact"]
        )
        assert row["critical_arrival_probability_exact"].startswith("from float data (the exact text: ")
        assert float(row["critical_arrival_probability"]) == full["critical_arrival_probability"]
