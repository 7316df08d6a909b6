"""The shipped pre-commit hook and composite action run ``kfio check``.

``pre-commit try-repo`` installs this repository into a fresh environment
from a committed copy, so the test commits a temporary copy of the package
and runs the hook in a temporary copy of examples/check/ (a design team's
repository).  The install is offline: the hook's virtualenv sees this
interpreter's packages and pip installs kfio alone, without its dependencies.
A real user's hook environment installs kfio with its dependencies from the
package index instead.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from support.check_layout import EXAMPLE

ROOT = Path(__file__).resolve().parents[2]


def _git(cwd: Path, *args: str) -> None:
    env = {**os.environ, "GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@example.org"}
    env.update(GIT_COMMITTER_NAME="t", GIT_COMMITTER_EMAIL="t@example.org")
    subprocess.run(["git", *args], cwd=cwd, env=env, check=True, capture_output=True)


def _repo(src_files: dict[Path, Path], dest: Path) -> Path:
    for src, rel in src_files.items():
        target = dest / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        if src.is_dir():
            shutil.copytree(src, target, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
        else:
            shutil.copy2(src, target)
    _git(dest, "init", "-q")
    _git(dest, "add", "-A")
    _git(dest, "commit", "-q", "-m", "copy")
    return dest


def test_hook_manifest_and_action_run_kfio_check():
    (hook,) = yaml.safe_load((ROOT / ".pre-commit-hooks.yaml").read_text())
    assert hook["id"] == "kfio-check" and hook["entry"] == "kfio check" and hook["pass_filenames"] is False
    action = yaml.safe_load((ROOT / "action.yml").read_text())
    assert action["runs"]["using"] == "composite"
    run = "\n".join(step["run"] for step in action["runs"]["steps"])
    assert 'kfio" check "$KFIO_CHECK_FILE" --junit "$KFIO_CHECK_JUNIT"' in run and "GITHUB_STEP_SUMMARY" in run
    assert action["inputs"]["file"]["default"] == "kfio-check.json"


@pytest.mark.slow
@pytest.mark.parametrize(("name", "code"), [("kfio-check.json", 0), ("kfio-check-failing.json", 1)])
def test_action_check_step_writes_junit_and_summary_and_passes_the_exit_code_on(tmp_path, name, code):
    """The action's `kfio check` step, run by bash as a runner would, with kfio as the installed one."""
    action = yaml.safe_load((ROOT / "action.yml").read_text())
    step = next(s for s in action["runs"]["steps"] if s["name"] == "kfio check")
    venv_bin = tmp_path / "runner" / "kfio-venv" / "bin"
    venv_bin.mkdir(parents=True)
    kfio = shutil.which("kfio", path=str(Path(sys.executable).parent)) or shutil.which("kfio")
    assert kfio is not None
    (venv_bin / "kfio").symlink_to(kfio)
    summary = tmp_path / "summary.md"
    summary.write_text("earlier step\n")
    env = {
        **os.environ,
        "RUNNER_TEMP": str(tmp_path / "runner"),
        "GITHUB_STEP_SUMMARY": str(summary),
        "KFIO_CHECK_FILE": name,
        "KFIO_CHECK_JUNIT": str(tmp_path / "out.xml"),
        "KFIO_CHECK_BUDGET": "300",
    }
    done = subprocess.run(
        ["bash", "-c", step["run"]], cwd=EXAMPLE, env=env, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == code, done.stderr
    assert (tmp_path / "out.xml").read_text().startswith("<?xml")
    text = summary.read_text()
    assert text.startswith("earlier step\n### kfio check: `" + name + "`")  # appended, not overwritten
    assert ("**FAIL**" in text) == bool(code)


@pytest.mark.slow
def test_pre_commit_try_repo_runs_the_hook(tmp_path):
    pre_commit = shutil.which("pre-commit", path=str(Path(sys.executable).parent)) or shutil.which("pre-commit")
    if pre_commit is None:
        pytest.fail("pre-commit is part of the test extra; install it with pip install -e '.[test]'")
    files = {ROOT / name: Path(name) for name in ("pyproject.toml", "README.md", "LICENSE", ".pre-commit-hooks.yaml")}
    files.update({ROOT / name: Path(name) for name in ("analyzer", "service")})
    hook_repo = _repo(files, tmp_path / "kfio")
    design = _repo({EXAMPLE: Path(".")}, tmp_path / "design")
    # The hook's environment sees kfio's dependencies where this interpreter has them (its own
    # site-packages through PYTHONPATH, which does not run their .pth files, so the editable kfio of
    # a checkout stays out; the base interpreter's as system site packages), so pip installs kfio alone.
    sites = [p for p in sys.path if p.endswith(("site-packages", "dist-packages")) and os.path.isdir(p)]
    env = {
        **os.environ,
        "PRE_COMMIT_HOME": str(tmp_path / "cache"),
        "PYTHONPATH": os.pathsep.join(sites),
        "VIRTUALENV_SYSTEM_SITE_PACKAGES": "1",
        "PIP_NO_DEPS": "1",
        "PIP_NO_BUILD_ISOLATION": "0",  # pip reads this variable inverted: 0 turns build isolation off
        "PIP_NO_INDEX": "1",
    }

    def try_repo() -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [pre_commit, "try-repo", str(hook_repo), "kfio-check", "--all-files", "--verbose"],
            cwd=design,
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )

    ok = try_repo()
    assert ok.returncode == 0, ok.stdout[-3000:] + ok.stderr[-3000:]
    assert "Passed" in ok.stdout and "all requirements hold" in ok.stdout
    # the failing check file in the default place: the hook fails, and says what failed
    shutil.copy2(design / "kfio-check-failing.json", design / "kfio-check.json")
    _git(design, "commit", "-q", "-am", "tighter requirements")
    bad = try_repo()
    assert bad.returncode == 1, bad.stdout[-3000:] + bad.stderr[-3000:]
    assert "Failed" in bad.stdout
    assert re.search(r"FAIL +two-state plant on the radio link +trace_V_bar_at_most +8\.6\d* +<= 8", bad.stdout)
