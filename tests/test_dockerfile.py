"""The Dockerfile's invariants, read from the file (CI cannot pull base images, so nothing is built here).

scripts/container.sh builds and runs the image with buildah (docs/deployment.md records a run), and
tests/service/server/test_service_docker.py replays its install and start commands in a virtual environment.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[1]


def instructions() -> list[tuple[str, str]]:
    """``(INSTRUCTION, arguments)`` of the Dockerfile, continuation lines joined, comments dropped."""
    out, pending = [], ""
    for raw in (ROOT / "Dockerfile").read_text().splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if line.endswith("\\"):
            pending += line[:-1] + " "
            continue
        word, _, rest = (pending + line).partition(" ")
        out.append((word.upper(), rest.strip()))
        pending = ""
    return out


def stages() -> list[list[tuple[str, str]]]:
    out: list[list[tuple[str, str]]] = []
    for kind, args in instructions():
        if kind == "FROM":
            out.append([])
        if out:
            out[-1].append((kind, args))
    return out


def test_two_stages_from_a_configurable_slim_python() -> None:
    steps = instructions()
    assert ("ARG", "BASE_IMAGE=python:3.11-slim") in steps[: [k for k, _ in steps].index("FROM")]
    builder, runtime = stages()
    assert builder[0] == ("FROM", "${BASE_IMAGE} AS builder") and runtime[0] == ("FROM", "${BASE_IMAGE}")
    assert ("COPY", "--from=builder /opt/kfio /opt/kfio") in runtime
    assert not any(k in ("COPY", "ADD") and "--from" not in a for k, a in runtime)  # no sources in the runtime stage
    assert not any(k == "RUN" and "pip" in a for k, a in runtime)  # installed in the builder only


def test_the_build_is_pinned_by_constraints_covering_every_dependency() -> None:
    builder, _ = stages()
    assert any(k == "COPY" and "constraints.txt" in a.split() for k, a in builder)
    installs = [a for k, a in builder if k == "RUN" and "pip install" in a]
    assert installs and all("--constraint constraints.txt" in a for a in installs)
    assert any("[control,sweep]" in a for a in installs)  # python-control and the sweep engine inside

    pins = {}
    for line in (ROOT / "constraints.txt").read_text().splitlines():
        if line and not line.startswith("#"):
            name, _, version = line.partition("==")
            assert version, f"constraints.txt: {line!r} is not name==version"
            pins[canonicalize_name(name)] = version
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = project.get("optional-dependencies", {})
    needed = project["dependencies"] + extras.get("control", []) + extras.get("sweep", [])
    for text in needed:
        req = Requirement(text)
        name = canonicalize_name(req.name)
        assert name in pins, f"constraints.txt lacks {req.name} (regenerate: python scripts/constraints.py)"
        assert req.specifier.contains(pins[name], prereleases=True), f"{name}=={pins[name]} breaks {text}"


def test_oci_labels_from_build_arguments() -> None:
    _, runtime = stages()
    labels = " ".join(a for k, a in runtime if k == "LABEL")
    args = {a.split("=")[0] for k, a in runtime if k == "ARG"}
    for key, arg in (("source", "SOURCE"), ("version", "VERSION"), ("revision", "REVISION")):
        assert f'org.opencontainers.image.{key}="${{{arg}}}"' in labels and arg in args, key
    license = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["license"]["text"]
    assert f'org.opencontainers.image.licenses="{license}"' in labels


def test_runs_as_a_non_root_user_and_the_healthcheck_follows_kfio_port() -> None:
    _, runtime = stages()
    kinds = [k for k, _ in runtime]
    user = dict(runtime)["USER"]
    assert user == "10001" and any(k == "RUN" and "useradd" in a and "--uid 10001" in a for k, a in runtime)
    assert kinds.index("USER") > max(i for i, k in enumerate(kinds) if k == "RUN")  # installs as root, runs as not
    env = " ".join(a for k, a in runtime if k == "ENV")
    assert "KFIO_PORT=8000" in env and "KFIO_HOST=0.0.0.0" in env and dict(runtime)["EXPOSE"] == "8000"
    health = dict(runtime)["HEALTHCHECK"]
    command = health.split(" CMD ", 1)[1]
    assert not command.startswith("[")  # shell form: the shell expands KFIO_PORT when the check runs
    assert "${KFIO_PORT:-8000}/healthz" in command and "urllib.request" in command and "curl" not in command
    assert "8000" not in dict(runtime)["CMD"]  # kfio serve reads KFIO_PORT


def test_dockerignore_keeps_the_context_small_and_the_build_inputs_in() -> None:
    ignored = {p.strip() for p in (ROOT / ".dockerignore").read_text().splitlines() if p and not p.startswith("#")}
    assert {".git", ".venv"} <= ignored
    for needed in ("constraints.txt", "pyproject.toml", "README.md", "LICENSE", "analyzer", "service"):
        assert needed not in ignored and (ROOT / needed).exists(), needed


def test_the_container_script_builds_with_buildah_as_documented() -> None:
    script = (ROOT / "scripts" / "container.sh").read_text()
    assert re.search(r"buildah bud --isolation chroot --format docker", script)
    assert ". scripts/vfs-storage.sh" in script and "BASE_IMAGE" in script
    assert 'driver = "vfs"' in (ROOT / "scripts" / "vfs-storage.sh").read_text()
    for probe in ("/healthz", "/v1/analyze", "/v1/sweeps", "kfio sweep", "buildah images --format"):
        assert probe in script, probe
