"""Replay the Dockerfile without Docker: install and start as the image would.

No Docker engine runs here, so the image build itself is unverified.  This
test reads the Dockerfile, copies what its ``COPY`` lines name (minus
``.dockerignore``), runs its ``RUN pip install`` line in a fresh virtual
environment, starts its ``CMD`` with the installed ``kfio`` (on 127.0.0.1 and
a free port instead of 0.0.0.0:8000) and runs its ``HEALTHCHECK`` command.

The pip line runs as written.  The virtual environment sees the machine's
packages (``--system-site-packages``), so the runtime dependencies are
already satisfied and the only downloads are pip's build requirements
(setuptools, wheel) from the configured package index; nothing else leaves
the machine.  The ``useradd``/``USER`` lines are checked for presence only.
"""

from __future__ import annotations

import fnmatch
import json
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import httpx
import pytest

from kfio.service.api.schemas import REQUEST_EXAMPLES

from support.live_server import REPO, LiveServer

pytestmark = pytest.mark.slow


def instructions(text: str) -> list[tuple[str, str]]:
    """``(INSTRUCTION, arguments)`` pairs, continuation lines joined, comments dropped."""
    out: list[tuple[str, str]] = []
    pending = ""
    for raw in text.splitlines():
        line = raw.strip()
        if not pending and (not line or line.startswith("#")):
            continue
        if line.endswith("\\"):
            pending += line[:-1] + " "
            continue
        line = pending + line
        pending = ""
        word, _, rest = line.partition(" ")
        out.append((word.upper(), rest.strip()))
    return out


def ignored(rel: str, patterns: list[str]) -> bool:
    parts = Path(rel).parts
    for pat in patterns:
        pat = pat.removeprefix("**/")
        if fnmatch.fnmatch(rel, pat) or any(fnmatch.fnmatch(p, pat) for p in parts):
            return True
    return False


def copy_context(sources: list[str], dest: Path, patterns: list[str]) -> None:
    """Docker's ``COPY``: a directory's *contents* go into ``dest``; files go into it by name."""
    dest.mkdir(parents=True, exist_ok=True)
    for src in sources:
        assert not ignored(src, patterns), f"COPY {src} is excluded by .dockerignore"
        path = REPO / src
        assert path.exists(), f"the Dockerfile copies {src}, which is not in the repository"
        if path.is_dir():
            skip = lambda d, names: [n for n in names if ignored(n, patterns)]  # noqa: E731
            shutil.copytree(path, dest, ignore=skip, dirs_exist_ok=True)
        else:
            shutil.copy2(path, dest / path.name)


def test_dockerfile_install_and_start_commands_work(tmp_path: Path) -> None:
    steps = instructions((REPO / "Dockerfile").read_text())
    patterns = [
        p.strip() for p in (REPO / ".dockerignore").read_text().splitlines() if p.strip() and not p.startswith("#")
    ]
    kinds = [k for k, _ in steps]
    assert steps[0][0] == "FROM" and steps[0][1].startswith("python:3.11-slim")
    assert any(k == "RUN" and "useradd" in a for k, a in steps) and dict(steps)["USER"] not in ("root", "0")
    assert kinds.index("USER") > max(i for i, (k, a) in enumerate(steps) if k == "RUN")  # installs as root, runs as not

    image = tmp_path / "image"
    workdir = image
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PIP_REQUIRE_VIRTUALENV")}
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True, timeout=120)
    bindir = venv / "bin"
    installed = False
    for kind, args in steps:
        if kind == "ENV":
            for pair in shlex.split(args):
                key, _, value = pair.partition("=")
                env[key] = value
        elif kind == "WORKDIR":
            workdir = image / args.lstrip("/")
            workdir.mkdir(parents=True, exist_ok=True)
        elif kind == "COPY":
            *sources, dest = shlex.split(args)
            copy_context(sources, workdir / dest, patterns)
        elif kind == "RUN" and args.startswith("pip "):
            argv = [str(bindir / "python"), "-m", *shlex.split(args)]
            done = subprocess.run(argv, cwd=workdir, env=env, capture_output=True, text=True, timeout=300)
            assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
            installed = True
    assert installed, "the Dockerfile has no RUN pip install line"

    # the installed package is used, not this checkout
    where = subprocess.run(
        [str(bindir / "python"), "-c", "import kfio.service; print(kfio.service.__file__)"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout.strip()
    assert where.startswith(str(venv)), where

    cmd = json.loads(dict(steps)["CMD"])
    assert cmd[:2] == ["kfio", "serve"] and "--host" in cmd and cmd[cmd.index("--host") + 1] == "0.0.0.0"
    assert dict(steps)["EXPOSE"] == cmd[cmd.index("--port") + 1] == "8000"
    health = dict(steps)["HEALTHCHECK"]
    assert "CMD" in health
    health_cmd = json.loads(health.split("CMD", 1)[1])

    with LiveServer(command=[str(bindir / cmd[0]), *cmd[1:]], env=env, workers=1, cwd=tmp_path) as server:
        assert httpx.get(f"{server.url}/healthz").json() == {"status": "ok"}
        probe = [str(bindir / health_cmd[0]), *(a.replace(":8000", f":{server.port}") for a in health_cmd[1:])]
        assert subprocess.run(probe, env=env, timeout=30).returncode == 0
        r = httpx.post(f"{server.url}/v1/analyze", json=REQUEST_EXAMPLES["seed004-scalar"]["value"], timeout=60)
        assert r.status_code == 200 and r.json()["verdict"] == "stable"
        # the web page, its examples and the docs' assets ship inside the installed (non-editable) package
        for path in (
            "/",
            "/static/app.js",
            "/static/app.css",
            "/static/examples/index.json",
            "/docs-assets/swagger-ui-bundle.js",
        ):
            assert httpx.get(f"{server.url}{path}", timeout=10).status_code == 200, path
        examples = httpx.get(f"{server.url}/static/examples/index.json").json()
        for example in examples:
            assert httpx.get(f"{server.url}/static/examples/{example['id']}.json").status_code == 200, example
