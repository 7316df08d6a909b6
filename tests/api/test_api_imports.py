"""What ``import kfio`` and the ``kfio`` command load (the import set, not a time)."""

from __future__ import annotations

import json
import subprocess
import sys

import kfio

HEAVY = ("cvxpy", "matplotlib", "fastapi", "uvicorn", "scipy.stats")


def loaded_after(code: str) -> set[str]:
    """Modules in ``sys.modules`` after running ``code`` in a fresh interpreter."""
    probe = f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120, check=True)
    return set(json.loads(out.stdout.strip().splitlines()[-1]))


def heavy(modules: set[str]) -> set[str]:
    return {m for m in modules if any(m == h or m.startswith(h + ".") for h in HEAVY)}


def test_import_kfio_loads_no_numerical_or_web_stack():
    mods = loaded_after("import kfio")
    assert heavy(mods) == set()
    assert not {"sympy", "numpy", "mpmath", "flint"} & mods  # everything is imported when first used


def test_the_cli_parser_loads_no_analyzer():
    # what `kfio --help` and `kfio --version` pay for: command modules import the analyzer in their _run
    mods = loaded_after("from kfio.service.cli import build_parser; build_parser()")
    assert heavy(mods) == set() and "sympy" not in mods and "kfio.stability" not in mods


def test_an_analysis_through_the_api_loads_none_of_the_heavy_modules():
    mods = loaded_after(
        "import kfio, numpy as np\n"
        "s = kfio.System(A=np.array([[1.25, 0], [1, 1.1]]), C=[[1, 1]], Q=20 * np.eye(2), R=[[2.5]])\n"
        "r = kfio.analyze(s, kfio.gilbert_elliott(failure_rate=0.1, recovery_rate=0.6))\n"
        "print(r.to_json())"
    )
    assert heavy(mods) == set() and "sympy" in mods


def test_every_public_name_resolves():
    for name in kfio.__all__:
        assert getattr(kfio, name) is not None, name
    assert set(kfio.__all__) <= set(dir(kfio))
    assert kfio.System.__module__ == "kfio._system" and kfio.analyze.__module__ == "kfio._api"
