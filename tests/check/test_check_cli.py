"""``kfio check``: exit codes, the table, JSON and Markdown, TOML, the default file, bad check files."""

from __future__ import annotations

import json

import pytest

from kfio.service import exitcodes

from support.check_layout import EXAMPLE, edit, run_cli


def test_passing_example_exits_0_with_a_table(example_runs):
    run = example_runs["kfio-check.json"]
    assert run["code"] == exitcodes.STABLE == 0, run["err"]
    lines = run["out"].splitlines()
    assert lines[0].split()[:3] == ["status", "entry", "requirement"]
    statuses = [line.split()[0] for line in lines[2:] if line.strip() and not line.startswith("kfio check")]
    spec = json.loads((EXAMPLE / "kfio-check.json").read_text())
    assert statuses == ["PASS"] * sum(len(e["requirements"]) for e in spec["checks"])
    assert "all requirements hold" in lines[-1] and run["err"] == ""


def test_failing_example_exits_1_and_says_measured_vs_required(example_runs):
    run = example_runs["kfio-check-failing.json"]
    assert run["code"] == exitcodes.UNSTABLE == 1
    result = json.loads(run["out"])
    assert result["status"] == "fail" and result["failed"] == 4 and result["passed"] == 1
    failed = {(o["entry"], o["requirement"]): o for o in result["outcomes"] if o["status"] == "fail"}
    vbar = failed[("two-state plant on the radio link", "trace_V_bar_at_most")]
    assert vbar["required"] == "<= 8" and float(vbar["measured"]) > 8
    assert failed[("two-state plant on the bursty link", "verdict")]["measured"] == "unstable"
    assert "requirements FAIL" in run["err"]


def test_markdown_summary_lists_failures_first(example_runs):
    md = example_runs["kfio-check-failing.json"]["markdown"].splitlines()
    assert md[0].startswith("### kfio check: ") and "1 passed, 4 failed, 0 errors" in md[2]
    rows = [line for line in md if line.startswith("| ") and "---" not in line][1:]
    assert [r.split("|")[1].strip() for r in rows] == ["**FAIL**"] * 4 + ["pass"]
    assert any("`trace_V_bar_at_most` | 8.6" in r and r.endswith("| <= 8 |") for r in rows)
    passing = example_runs["kfio-check.json"]["markdown"]
    assert "**FAIL**" not in passing and "All requirements hold" in passing


def test_toml_file_gives_the_same_outcomes_as_json(capsys):
    code, out, _ = run_cli(capsys, str(EXAMPLE / "kfio-check.toml"), "--json", "--workers", "1")
    assert code == 0
    toml = {(o["entry"], o["requirement"]): o["measured"] for o in json.loads(out)["outcomes"]}
    code, out, _ = run_cli(capsys, str(EXAMPLE / "kfio-check.json"), "--json", "--workers", "1")
    json_ = {(o["entry"], o["requirement"]): o["measured"] for o in json.loads(out)["outcomes"]}
    assert toml and all(json_[k] == v for k, v in toml.items())


def test_toml_decimals_are_exact(layout, capsys):
    # 0.36 is 9/25 exactly: "at most 0.36" holds with equality, "at most 0.3599" does not
    for value, code in (("0.36", 0), ("0.3599", 1)):
        (layout / "k.toml").write_text(
            f'[[checks]]\nplant = "plants/scalar.json"\nchannel = "channels/radio.json"\n'
            f"[checks.requirements]\ncritical_arrival_probability_at_most = {value}\n"
        )
        assert run_cli(capsys, str(layout / "k.toml"), "--workers", "1")[0] == code, value


def test_default_file_is_kfio_check_json_here(layout, capsys, monkeypatch):
    monkeypatch.chdir(layout)
    (layout / "kfio-check.json").unlink()  # then kfio-check.toml is the one
    code, out, _ = run_cli(capsys, "--workers", "1")
    assert code == 0 and "trace_V_bar_at_most" in out
    (layout / "kfio-check.toml").unlink()
    code, _, err = run_cli(capsys)
    assert code == exitcodes.INVALID_INPUT and "no check file given" in err


@pytest.mark.parametrize(
    ("change", "field"),
    [
        (lambda t: t["checks"][0]["requirements"].update(margn="1/10"), "/checks/0/requirements/margn"),
        (lambda t: t["checks"][1]["requirements"].update(margin="1"), "/checks/1/requirements/margin"),
        (lambda t: t["checks"][0]["requirements"].update(verdict="bounded"), "/checks/0/requirements/verdict"),
        (lambda t: t["checks"][0]["requirements"]["outage"].pop("epsilon"), "/checks/0/requirements/outage/epsilon"),
        (lambda t: t["checks"][1].update(plant="plants/missing.json"), "/checks/1/plant"),
        (lambda t: t["checks"][1].update(name=t["checks"][0]["name"]), "/checks/1/name"),
        (lambda t: t.update(check=[]), "/check"),
        (lambda t: t["options"].update(time_budget_s=0), "/options/time_budget_s"),
        # a Monte Carlo over the simulation limits is a bad file, found before any work
        (
            lambda t: t["checks"][0]["requirements"]["outage"].update(trajectories=20000),
            "/checks/0/requirements/outage",
        ),
        (lambda t: t["checks"][1].update(options={"bounds": {"horizon": 0}}), "/checks/1/options"),
    ],
)
def test_bad_check_file_exits_2_naming_the_field(layout, capsys, change, field):
    edit(layout / "kfio-check.json", change)
    code, out, err = run_cli(capsys, str(layout / "kfio-check.json"))
    assert code == exitcodes.INVALID_INPUT and out == ""
    assert err.startswith(f"kfio: invalid input at {field}: ") and "Traceback" not in err


def test_bad_plant_file_names_the_entry_and_the_field_inside(layout, capsys):
    edit(layout / "plants" / "scalar.json", lambda t: t["system"].update(R=[[-1]]))
    code, _, err = run_cli(capsys, str(layout / "kfio-check.json"))
    assert code == exitcodes.INVALID_INPUT
    assert err.startswith("kfio: invalid input at /checks/1/plant: /system/R")


def test_bounds_requirement_without_noise_is_refused_before_work(layout, capsys):
    edit(layout / "plants" / "scalar.json", lambda t: [t["system"].pop(k) for k in ("Q", "R")])
    code, _, err = run_cli(capsys, str(layout / "kfio-check.json"))
    assert code == exitcodes.INVALID_INPUT and "/checks/1/plant" in err and "need Q and R" in err


@pytest.mark.parametrize("workers", ["1", "2"])
def test_budget_exceeded_exits_4(capsys, workers):
    code, out, err = run_cli(capsys, str(EXAMPLE / "kfio-check.json"), "--time-budget", "0.01", "--workers", workers)
    assert code == exitcodes.BUDGET == 4
    assert "the budget ran out" in err and "budget-exceeded" in out


def test_help_documents_the_exit_codes(capsys):
    with pytest.raises(SystemExit):
        from kfio.service.cli import build_parser

        build_parser().parse_args(["check", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for phrase in ("Exit 0 all requirements hold", "1 a requirement fails", "2 invalid check file", "4 budget"):
        assert phrase in text


def test_parallel_and_serial_runs_agree(capsys):
    results = []
    for workers in ("1", "2"):
        code, out, _ = run_cli(capsys, str(EXAMPLE / "kfio-check-failing.json"), "--json", "--workers", workers)
        results.append((code, json.loads(out)))
    (c1, r1), (c2, r2) = results
    assert c1 == c2 == 1 and r1["workers"] == 1 and r2["workers"] == 2
    strip = [{k: v for k, v in o.items() if k != "seconds"} for o in r1["outcomes"]]
    assert strip == [{k: v for k, v in o.items() if k != "seconds"} for o in r2["outcomes"]]
