"""CI and the contributors' tools run the same checks with the same configuration.

* ``.ci/run``'s install line and test command are, joined, the README's second
  quick-start command: what a contributor runs is what CI runs.
* Every install in CI uses ``constraints.txt`` (the versions the container
  ships), and the fast tier runs before the slow one, each test in exactly one.
* The library and the service are type-checked with ``strict = true`` and no
  per-module exception, and the pre-commit hook runs the same type-check command
  as CI (``scripts/typecheck.py``, which checks the package as it installs, so
  the service's calls into the library are typed).
"""

from __future__ import annotations

import re
import shlex
import sys
import tomllib

from support.paths import ROOT

CI = (ROOT / ".ci" / "run").read_text()
CI_LINES = [line for line in CI.splitlines() if line and not line.startswith(("#", "set ", "cd ", "export "))]
README = (ROOT / "README.md").read_text()
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def _console_blocks(text: str) -> list[str]:
    return re.findall(r"^```console\n(.*?)^```$", text, flags=re.M | re.S)


def test_the_readme_test_command_is_what_ci_runs() -> None:
    install = next(line for line in CI_LINES if "pip install" in line)
    test = next(line for line in CI_LINES if "-m pytest" in line)
    quick_start = [b.strip() for b in _console_blocks(README.split("## Quick start", 1)[1]) if "pytest" in b]
    assert quick_start, "the README's quick start has no test command"
    assert quick_start[0] == f"{install} && {test}"


def test_ci_installs_under_the_constraints() -> None:
    installs = [part for line in CI_LINES for part in line.split("&&") if "pip install" in part]
    assert installs
    for part in installs:
        words = shlex.split(part)
        assert "-c" in words and words[words.index("-c") + 1] == "constraints.txt", part
    assert (ROOT / "constraints.txt").is_file()


def test_the_fast_tier_runs_first_and_the_tiers_partition_the_suite() -> None:
    runs = [shlex.split(part) for line in CI_LINES for part in line.split("&&") if "-m pytest" in part]
    markers = [words[words.index("-m", words.index("pytest")) + 1] for words in runs]
    assert markers == ["not slow", "slow"]
    assert all("--cov=kfio" in words for words in runs)  # line coverage of the library and the service
    assert "--cov-append" in runs[1]  # one report over both tiers


def test_library_and_service_are_checked_strictly() -> None:
    mypy = PYPROJECT["tool"]["mypy"]
    assert mypy.get("strict") is True
    # no module of kfio's may turn a flag of --strict back off (third-party modules may be read leniently)
    for override in mypy.get("overrides", []):
        modules = [override["module"]] if isinstance(override["module"], str) else override["module"]
        assert not [m for m in modules if m.split(".")[0] == "kfio"], override


def test_ci_and_the_pre_commit_hook_type_check_the_installed_package() -> None:
    ci = next(line for line in CI_LINES if "typecheck" in line)
    assert ci.strip() == ".venv/bin/python scripts/typecheck.py"
    hooks = (ROOT / ".pre-commit-config.yaml").read_text()
    entries = re.findall(r"entry: (.*typecheck.*)$", hooks, flags=re.M)
    assert entries == [ci.strip()]
    assert not [line for line in CI_LINES if re.search(r"\bmypy\b", line)]  # no second, folder-named run


def test_the_type_check_resolves_kfio_to_the_checkout() -> None:
    """The link tree maps kfio to analyzer/ and kfio.service to service/, so no kfio import is Any."""
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import typecheck
    finally:
        sys.path.pop(0)
    links = typecheck.link_tree(ROOT, ROOT / ".mypy_cache" / "kfio-links-test")
    try:
        package = links / "kfio"
        assert (package / "_api.py").resolve() == (ROOT / "analyzer" / "_api.py").resolve()
        assert (package / "service" / "app.py").resolve() == (ROOT / "service" / "app.py").resolve()
        names = {p.name for p in (ROOT / "analyzer").iterdir() if p.name != "__pycache__"}
        assert {p.name for p in package.iterdir()} == names | {"service"}
    finally:
        import shutil

        shutil.rmtree(links)
