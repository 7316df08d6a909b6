"""Replay the Dockerfile without Docker: build, install and start as the image would.

No Docker engine runs here (scripts/container.sh builds the real image with
buildah; docs/deployment.md records a run).  This test reads the Dockerfile,
copies what the builder stage's ``COPY`` lines name (minus ``.dockerignore``),
runs the builder's ``RUN`` lines with the image's virtual environment
``/opt/kfio`` and wheel folder ``/dist`` moved under a temporary folder, then
starts the runtime stage's ``CMD`` in its ``ENV`` (with ``KFIO_HOST`` and
``KFIO_PORT`` moved to 127.0.0.1 and a free port) and runs its
``HEALTHCHECK`` command, which must follow ``KFIO_PORT``.

The virtual environment sees the machine's packages
(``--system-site-packages``) and the replay leaves out ``--constraint
constraints.txt`` (tests/test_dockerfile.py checks that file), so the
runtime dependencies are already satisfied and the only downloads are pip's
build requirements (setuptools, wheel) from the configured package index;
nothing else leaves the machine.
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

from support.live_server import REPO, LiveServer, free_port

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


def stages(steps: list[tuple[str, str]]) -> list[list[tuple[str, str]]]:
    """The instructions of each ``FROM`` stage (``ARG`` lines before the first ``FROM`` dropped)."""
    out: list[list[tuple[str, str]]] = []
    for kind, args in steps:
        if kind == "FROM":
            out.append([])
        if out:
            out[-1].append((kind, args))
    return out


def test_dockerfile_install_and_start_commands_work(tmp_path: Path) -> None:
    steps = instructions((REPO / "Dockerfile").read_text())
    patterns = [
        p.strip() for p in (REPO / ".dockerignore").read_text().splitlines() if p.strip() and not p.startswith("#")
    ]
    builder, runtime = stages(steps)
    assert builder[0][1].endswith(" AS builder")

    image = tmp_path / "image"
    venv, dist = tmp_path / "opt-kfio", tmp_path / "dist"
    moved = {"/opt/kfio": str(venv), "/dist": str(dist)}

    def move(text: str) -> str:
        for old, new in moved.items():
            text = text.replace(old, new)
        return text

    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PIP_REQUIRE_VIRTUALENV")}
    env["PATH"] = f"{Path(sys.executable).parent}:{env['PATH']}"  # `python` is this interpreter
    workdir = image
    ran = []
    for kind, args in builder[1:]:
        if kind == "ENV":
            env.update(pair.split("=", 1) for pair in shlex.split(args))
        elif kind == "WORKDIR":
            workdir = image / args.lstrip("/")
            workdir.mkdir(parents=True, exist_ok=True)
        elif kind == "COPY":
            *sources, dest = shlex.split(args)
            copy_context(sources, workdir / dest, patterns)
        elif kind == "RUN":
            command = move(args).replace("python -m venv ", "python -m venv --system-site-packages ")
            command = command.replace("--constraint constraints.txt ", "")
            done = subprocess.run(
                ["bash", "-c", command], cwd=workdir, env=env, capture_output=True, text=True, timeout=600
            )
            assert done.returncode == 0, command + "\n" + done.stdout[-3000:] + done.stderr[-3000:]
            ran.append(command)
    assert any("pip install" in c and "[control,sweep]" in c for c in ran), ran
    bindir = venv / "bin"

    # the installed package is used, not this checkout, and the extras are there
    where = subprocess.run(
        [str(bindir / "python"), "-c", "import kfio.service, control, dask.distributed; print(kfio.service.__file__)"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert where.returncode == 0 and where.stdout.startswith(str(venv)), where.stderr

    run_env = dict(env)
    for kind, args in runtime:
        if kind == "ENV":
            for pair in shlex.split(args):
                key, _, value = pair.partition("=")
                run_env[key] = move(value).replace("$PATH", env["PATH"])
    assert run_env["KFIO_HOST"] == "0.0.0.0" and run_env["KFIO_PORT"] == dict(runtime)["EXPOSE"] == "8000"
    cmd = json.loads(dict(runtime)["CMD"])
    assert cmd == ["kfio", "serve"]  # host and port come from KFIO_HOST and KFIO_PORT
    health = dict(runtime)["HEALTHCHECK"].split(" CMD ", 1)[1]
    assert not health.startswith("["), "the HEALTHCHECK must be shell form to read KFIO_PORT"

    server = LiveServer(command=[str(bindir / cmd[0]), *cmd[1:]], cwd=tmp_path)
    server.argv = [str(bindir / cmd[0]), *cmd[1:], "--workers", "1"]  # no --host/--port: the environment's
    server.env = {**run_env, "KFIO_HOST": "127.0.0.1", "KFIO_PORT": str(server.port)}
    with server:
        assert httpx.get(f"{server.url}/healthz").json() == {"status": "ok"}
        assert subprocess.run(["sh", "-c", health], env=server.env, timeout=30).returncode == 0
        other = {**server.env, "KFIO_PORT": str(free_port())}  # nothing listens there: unhealthy
        assert subprocess.run(["sh", "-c", health], env=other, timeout=30, capture_output=True).returncode == 1
        r = httpx.post(f"{server.url}/v1/analyze", json=REQUEST_EXAMPLES["seed004-scalar"]["value"], timeout=60)
        assert r.status_code == 200 and r.json()["verdict"] == "stable"
        # the web page, its example requests and the docs' assets ship inside the installed (non-editable) package
        for path in (
            "/",
            "/static/app.js",
            "/static/app.css",
            "/static/requests/index.json",
            "/docs-assets/swagger-ui-bundle.js",
        ):
            assert httpx.get(f"{server.url}{path}", timeout=10).status_code == 200, path
        examples = httpx.get(f"{server.url}/static/requests/index.json").json()
        for example in examples:
            assert httpx.get(f"{server.url}/static/requests/{example['id']}.json").status_code == 200, example
