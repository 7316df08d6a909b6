"""A check file reads only what it owns.

Every plant, channel and loop path must lead, symlinks followed, to a regular
file under the check file's directory (or under a directory given with
``--allow-outside``).  Anything else is refused before it is opened, exit 2,
with one message whatever the reason (so an error never tells whether a file
outside exists); a FIFO is refused at once, never opened.  What a referenced
file holds is never quoted in an error: the field and the file are named.
"""

from __future__ import annotations

import html
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from kfio.check import load_check, parse_check
from kfio.errors import InvalidInput
from kfio.service import exitcodes

from support.check_layout import EXAMPLE, run_cli

SECRET = "ghp_SECRETTOKEN123"
SECRET_MODEL = "hunter2-secret"
REFUSED = "is not a regular file inside the check file's directory"


@pytest.fixture()
def world(tmp_path: Path) -> dict[str, Path]:
    """A design repository (a copy of examples/check/) and, beside it, a directory it must not read."""
    repo = tmp_path / "repo"
    shutil.copytree(EXAMPLE, repo)
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "credentials.json").write_text(json.dumps({"system": {"A": [[SECRET]], "C": [[1]]}}))
    (outside / "plant.json").write_text((EXAMPLE / "plants" / "scalar.json").read_text())
    (outside / "channel.toml").write_text(f'model = "{SECRET_MODEL}"\n')
    return {"repo": repo, "outside": outside, "tmp": tmp_path}


def _check_file(repo: Path, plant: str, channel: str = "channels/radio.json", name: str = "c.json") -> Path:
    entry = {"name": "e", "plant": plant, "channel": channel, "requirements": {"verdict": "stable"}}
    path = repo / name
    path.write_text(json.dumps({"checks": [entry]}))
    return path


def _refusal(capsys, check: Path, *flags: str) -> str:
    junit, md = check.parent / "out.xml", check.parent / "out.md"
    code, out, err = run_cli(capsys, str(check), "--workers", "1", "--junit", str(junit), "--markdown", str(md), *flags)
    assert code == exitcodes.INVALID_INPUT == 2, err
    assert out == "" and "Traceback" not in err and len(err.splitlines()) == 1
    for written in (junit, md):
        assert not written.exists() or SECRET not in written.read_text()
    return err


def _paths_out_of(world: dict[str, Path]) -> dict[str, str]:
    """Paths a check file in ``repo`` might use to reach ``outside/credentials.json``."""
    repo, outside = world["repo"], world["outside"]
    (repo / "plants" / "link.json").symlink_to(outside / "credentials.json")
    (repo / "linkdir").symlink_to(outside, target_is_directory=True)
    depth = len(repo.resolve().parts) - 1
    return {
        "dot-dot": "../outside/credentials.json",
        "dot-dot through a subdirectory": "plants/../../outside/credentials.json",
        "absolute": str(outside / "credentials.json"),
        "symlinked file": "plants/link.json",
        "symlinked directory": "linkdir/credentials.json",
        "far up to /etc/passwd": "../" * depth + "etc/passwd",
        "absolute /etc/passwd": "/etc/passwd",
    }


def test_every_path_out_of_the_directory_is_refused_before_reading(world, capsys):
    for label, ref in _paths_out_of(world).items():
        err = _refusal(capsys, _check_file(world["repo"], ref))
        assert err.startswith("kfio: invalid input at /checks/0/plant: the plant file "), label
        assert REFUSED in err and json.dumps(ref) in err, label  # names the path and the rule
        assert SECRET not in err and "root:" not in err, label


def test_a_missing_file_and_a_file_outside_get_the_same_message(world, capsys):
    repo = world["repo"]
    messages = {}
    for ref in ("../outside/credentials.json", "../outside/no-such-file.json", "../no-such-dir/x.json"):
        messages[ref] = _refusal(capsys, _check_file(repo, ref)).replace(json.dumps(ref), "PATH")
    messages["missing inside"] = _refusal(capsys, _check_file(repo, "plants/nope.json")).replace(
        json.dumps("plants/nope.json"), "PATH"
    )
    assert len(set(messages.values())) == 1, messages


@pytest.mark.parametrize("kind", ["directory", "device", "/dev/stdin", "fifo", "socket"])
def test_only_regular_files_are_read(world, capsys, kind):
    repo = world["repo"]
    ref = {"directory": "plants", "device": "null", "/dev/stdin": "/dev/stdin", "fifo": "p.fifo", "socket": "s"}[kind]
    if kind == "device":
        (repo / "null").symlink_to("/dev/null")
    elif kind == "fifo":
        os.mkfifo(repo / ref)
    elif kind == "socket":
        import socket

        with socket.socket(socket.AF_UNIX) as sock:
            sock.bind(str(repo / ref))
    err = _refusal(capsys, _check_file(repo, ref))
    assert REFUSED in err


def _cli(args: list[str], cwd: Path, timeout: float) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "kfio.service.cli", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        stdin=subprocess.DEVNULL,
    )


def test_a_fifo_is_refused_at_once_not_opened(world):
    """``open()`` of a FIFO with no writer blocks forever: kfio must stat first and refuse."""
    repo = world["repo"]
    os.mkfifo(repo / "plants" / "pipe.json")
    os.mkfifo(repo / "pipe-check.json")
    _check_file(repo, "plants/pipe.json")
    t0 = time.monotonic()
    done = _cli(["check", "c.json", "--time-budget", "2", "--workers", "1"], repo, timeout=60)
    assert done.returncode == 2, done.stderr
    assert "/checks/0/plant" in done.stderr and REFUSED in done.stderr
    # the check file itself may not be a FIFO either (the caller names it, so no confinement: regular only)
    done = _cli(["check", "pipe-check.json", "--workers", "1"], repo, timeout=60)
    assert done.returncode == 2 and "is not a regular file" in done.stderr, done.stderr
    assert time.monotonic() - t0 < 60  # neither run hung (the timeout above would have raised first)


def test_content_of_a_referenced_file_is_never_quoted(world, capsys):
    """A file the check file may read (inside, or allowed) is validated; its values are not repeated."""
    repo, outside = world["repo"], world["outside"]
    (repo / "plants" / "token.json").write_text((outside / "credentials.json").read_text())
    (repo / "channels" / "model.toml").write_text((outside / "channel.toml").read_text())
    (repo / "plants" / "key.json").write_text(json.dumps({"system": {"A": [[2]], "C": [[1]], "R": [[SECRET]]}}))
    cases = [
        ("plants/token.json", "channels/radio.json", "/checks/0/plant: /system/A/0/0: ", '"plants/token.json"'),
        ("plants/scalar.json", "channels/model.toml", "/checks/0/channel: /channel/model: ", '"channels/model.toml"'),
        ("plants/key.json", "channels/radio.json", "/checks/0/plant: /system/R/0/0: ", '"plants/key.json"'),
        ("../outside/credentials.json", "channels/radio.json", "/checks/0/plant: /system/A/0/0: ", "credentials"),
    ]
    for plant, channel, field, file_named in cases:
        err = _refusal(capsys, _check_file(repo, plant, channel), "--allow-outside", str(outside))
        assert err.startswith("kfio: invalid input at " + field), err
        assert file_named in err and "<value not shown>" in err
        assert SECRET not in err and SECRET_MODEL not in err and "hunter2" not in err
    # the same for a loop file
    (repo / "loop.json").write_text(json.dumps({"system": {"A": [[SECRET]]}}))
    (repo / "c.json").write_text(
        json.dumps({"checks": [{"loop": "loop.json", "requirements": {"loop_verdict": "stable"}}]})
    )
    err = _refusal(capsys, repo / "c.json")
    assert "/checks/0/loop" in err and SECRET not in err


def test_a_loop_file_outside_is_refused(world, capsys):
    repo = world["repo"]
    (repo / "c.json").write_text(
        json.dumps({"checks": [{"loop": "../outside/plant.json", "requirements": {"loop_verdict": "stable"}}]})
    )
    err = _refusal(capsys, repo / "c.json")
    assert err.startswith("kfio: invalid input at /checks/0/loop: the loop file ") and REFUSED in err


def test_allow_outside_opts_in_and_still_reads_regular_files_only(world, capsys):
    repo, outside = world["repo"], world["outside"]
    check = _check_file(repo, "../outside/plant.json")
    _refusal(capsys, check)
    code, out, err = run_cli(capsys, str(check), "--workers", "1", "--allow-outside", str(outside))
    assert code == 0 and "PASS" in out, err
    # through a symlink into the allowed directory, and with the flag given twice
    (repo / "plants" / "shared.json").symlink_to(outside / "plant.json")
    other = world["tmp"] / "other"
    other.mkdir()
    check = _check_file(repo, "plants/shared.json")
    code, out, err = run_cli(
        capsys, str(check), "--workers", "1", "--allow-outside", str(other), "--allow-outside", str(outside)
    )
    assert code == 0 and "PASS" in out, err
    # a FIFO in the allowed directory is still refused
    os.mkfifo(outside / "pipe.json")
    err = _refusal(capsys, _check_file(repo, "../outside/pipe.json"), "--allow-outside", str(outside))
    assert "or a directory given by --allow-outside" in err
    # a directory outside the allowed one is still refused, even with a prefix of the same name
    sibling = world["tmp"] / "outside-not"
    sibling.mkdir()
    shutil.copy(outside / "plant.json", sibling / "plant.json")
    _refusal(capsys, _check_file(repo, "../outside-not/plant.json"), "--allow-outside", str(outside))


def test_allow_outside_must_name_a_directory(world, capsys):
    check = _check_file(world["repo"], "plants/scalar.json")
    code, _, err = run_cli(capsys, str(check), "--allow-outside", str(world["outside"] / "plant.json"))
    assert code == 2 and err.startswith("kfio: invalid input at --allow-outside: ")


def test_the_library_applies_the_same_rules(world):
    repo, outside = world["repo"], world["outside"]
    tree = json.loads(_check_file(repo, "../outside/plant.json").read_text())
    with pytest.raises(InvalidInput, match=REFUSED) as err:
        parse_check(tree, repo)
    assert err.value.field == "/checks/0/plant"
    assert parse_check(tree, repo, allow_outside=[outside]).entries[0].name == "e"
    assert len(load_check(repo / "kfio-check.json").entries) >= 1  # the example layout reads only its own files


def test_paths_inside_stay_allowed(world, capsys):
    """Subdirectories, ``..`` that stays inside, and a symlink that stays inside are fine."""
    repo = world["repo"]
    (repo / "plants" / "alias.json").symlink_to(repo / "plants" / "scalar.json")
    for ref in (
        "plants/scalar.json",
        "channels/../plants/scalar.json",
        "plants/alias.json",
        str(repo / "plants/scalar.json"),
    ):
        code, out, err = run_cli(capsys, str(_check_file(repo, ref)), "--workers", "1")
        assert code == 0 and "PASS" in out, (ref, err)


ROOT = Path(__file__).resolve().parents[2]


def _action_step(tmp_path: Path, kfio: str, env: dict[str, str], cwd: Path) -> subprocess.CompletedProcess[str]:
    """The shipped action's ``kfio check`` step, run by bash as a runner would, with ``kfio`` as the tool."""
    import yaml

    action = yaml.safe_load((ROOT / "action.yml").read_text())
    step = next(s for s in action["runs"]["steps"] if s["name"] == "kfio check")
    venv_bin = tmp_path / "runner" / "kfio-venv" / "bin"
    venv_bin.mkdir(parents=True, exist_ok=True)
    (venv_bin / "kfio").unlink(missing_ok=True)
    (venv_bin / "kfio").symlink_to(kfio)
    full = {**os.environ, "RUNNER_TEMP": str(tmp_path / "runner"), "KFIO_CHECK_BUDGET": "", **env}
    full.pop("GITHUB_STEP_SUMMARY", None)
    return subprocess.run(["bash", "-c", step["run"]], cwd=cwd, env=full, capture_output=True, text=True, timeout=120)


def test_the_action_passes_each_allowed_directory_on(tmp_path):
    echo = tmp_path / "echo-args"
    echo.write_text('#!/bin/sh\nfor a in "$@"; do printf "<%s>" "$a"; done\n')
    echo.chmod(0o755)
    env = {
        "KFIO_CHECK_FILE": "c.json",
        "KFIO_CHECK_JUNIT": "j.xml",
        "KFIO_CHECK_ALLOW_OUTSIDE": "shared models\n\n../b\n",
    }
    done = _action_step(tmp_path, str(echo), env, tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.endswith("<--allow-outside><shared models><--allow-outside><../b>")
    done = _action_step(tmp_path, str(echo), {**env, "KFIO_CHECK_ALLOW_OUTSIDE": ""}, tmp_path)
    assert "--allow-outside" not in done.stdout


def test_the_action_refuses_a_path_out_and_keeps_the_secret_out_of_junit(world, tmp_path):
    kfio = shutil.which("kfio", path=str(Path(sys.executable).parent)) or shutil.which("kfio")
    assert kfio is not None
    repo = world["repo"]
    _check_file(repo, "../outside/credentials.json")
    env = {"KFIO_CHECK_FILE": "c.json", "KFIO_CHECK_JUNIT": str(tmp_path / "out.xml"), "KFIO_CHECK_ALLOW_OUTSIDE": ""}
    done = _action_step(tmp_path, kfio, env, repo)
    assert done.returncode == 2 and REFUSED in done.stderr and SECRET not in done.stdout + done.stderr
    assert not (tmp_path / "out.xml").exists()


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_run_time_error_does_not_quote_the_file_either(world, capsys, workers):
    """A plant file valid as a request, whose option fails only when the analysis resolves it."""
    repo = world["repo"]
    plant = json.loads((EXAMPLE / "plants" / "scalar.json").read_text())
    plant["channel"] = {"model": "bernoulli", "arrival_probability": "0.9"}
    plant["options"] = {"analyze": {"critical_parameter": f"/channel/{SECRET}"}}
    (repo / "plants" / "opt.json").write_text(json.dumps(plant))
    (repo / "c.json").write_text(
        json.dumps({"checks": [{"plant": "plants/opt.json", "requirements": {"verdict": "stable"}}]})
    )
    junit, md = repo / "out.xml", repo / "out.md"
    code, out, err = run_cli(
        capsys, str(repo / "c.json"), "--workers", workers, "--junit", str(junit), "--markdown", str(md)
    )
    assert code == exitcodes.UNSTABLE == 1, err
    # the table clips its cells; the JUnit message carries the whole error
    whole = html.unescape(junit.read_text())
    assert "/options/analyze/critical_parameter: <value not shown> names no arrival probability" in whole
    for text in (out, err, junit.read_text(), md.read_text()):
        assert SECRET not in text
