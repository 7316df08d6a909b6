"""Every code block of README.md and docs/*.md does what it says.

* ```` ```python ```` blocks run, in order and in one namespace per file, in a
  temporary directory that holds the repository's ``examples/``.  A block that
  cannot run (a signature list, a server session) says so in its info string,
  ```` ```python no-run: <why> ````, and such blocks stay few.
* ```` ```console ```` blocks: every ``kfio`` command line parses with the CLI's
  own parser, every ``python -m`` module exists, every repository path named
  exists.  The README's quick-start ``$ kfio ...`` lines run, with the exit
  code and the output they show.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import re
import shlex
from pathlib import Path

import pytest

from kfio.service.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^```([^\n`]*)\n(.*?)^```$", re.M | re.S)
NO_RUN = re.compile(r"^python no-run: (.{12,})$")
#: At most this many python blocks in all the docs may be exempt from running.
MAX_NO_RUN = 3
#: What the run of each file's blocks must print (the text the page shows beside the code).
PRINTS = {
    "python_api.md": [
        "StabilityReport(verdict='stable'",
        "System(A=[['5/4', '0'], ['1', '11/10']], C=[['1', '1']])",
    ],
}


def fences(path: Path) -> list[tuple[str, str]]:
    """``(info string, body)`` of each fenced block of ``path``, in order."""
    return [(m.group(1).strip(), m.group(2)) for m in FENCE.finditer(path.read_text(encoding="utf-8"))]


def python_blocks(path: Path) -> list[str]:
    return [body for info, body in fences(path) if info == "python"]


def _rel(path: Path) -> str:
    return str(path.relative_to(ROOT))


RUNNABLE = [p for p in DOCS if python_blocks(p)]


def test_the_docs_have_python_examples() -> None:
    names = {p.name for p in RUNNABLE}
    assert {"README.md", "python_api.md"} <= names


@pytest.mark.parametrize("path", RUNNABLE, ids=_rel)
def test_python_blocks_run(path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": "__docs__"}
    with contextlib.redirect_stdout(io.StringIO()) as out:
        for i, block in enumerate(python_blocks(path)):
            exec(compile(block, f"{_rel(path)} python block {i}", "exec"), namespace)  # noqa: S102 - our own docs
    for text in PRINTS.get(path.name, []):
        assert text in out.getvalue()


def test_python_blocks_that_do_not_run_are_few_and_say_why() -> None:
    infos = [(path.name, info) for path in DOCS for info, _ in fences(path) if info.startswith("python")]
    odd = [(name, info) for name, info in infos if info != "python" and not NO_RUN.match(info)]
    assert not odd, f"python blocks must be ```python or ```python no-run: <reason>: {odd}"
    exempt = [(name, info) for name, info in infos if info != "python"]
    assert len(exempt) <= MAX_NO_RUN, exempt


# --- console blocks ---------------------------------------------------------------------------------------------

_SEPARATORS = re.compile(r"&&|\|\||;|\|")


def console_commands(path: Path) -> list[str]:
    """The command lines of the console blocks of ``path`` (``$ `` prompts stripped; output lines left out).

    A block without any ``$`` prompt is all commands; a trailing ``\\`` joins lines.
    """
    out = []
    for info, body in fences(path):
        if info != "console":
            continue
        lines = body.replace("\\\n", " ").splitlines()
        prompted = any(line.startswith("$ ") for line in lines)
        out += [
            line[2:] if prompted else line for line in lines if line.strip() and (line.startswith("$ ") or not prompted)
        ]
    return out


def _segments(command: str) -> list[list[str]]:
    words = []
    for part in _SEPARATORS.split(command.replace("(", " ").replace(")", " ")):
        tokens = shlex.split(part, comments=True)
        if tokens:
            words.append(tokens)
    return words


def _repo_paths(tokens: list[str]) -> list[str]:
    paths = []
    for t in tokens:
        t = t.lstrip("@").split("::")[0]
        if re.match(r"^(examples|tests|docs|bench|analyzer|service|openapi)/", t):
            paths.append(t)
    return paths


def _check_segment(tokens: list[str]) -> None:
    head = Path(tokens[0]).name
    for p in _repo_paths(tokens):
        assert (ROOT / p).exists(), f"{p} does not exist"
    if head == "kfio":
        argv = tokens[1:]
        try:
            build_parser().parse_args(argv)
        except SystemExit as exc:  # --help and --version exit 0
            assert exc.code == 0, f"kfio {' '.join(argv)}: the CLI refuses these arguments"
    elif head.startswith("python") and "-m" in tokens:
        module = tokens[tokens.index("-m") + 1]
        if module not in ("venv", "pip", "pytest", "ruff", "mypy"):
            assert importlib.util.find_spec(module) is not None, f"no module {module}"
    elif head == "docker" and "build" in tokens:
        assert (ROOT / "Dockerfile").exists()


CONSOLE = [p for p in DOCS if console_commands(p)]


@pytest.mark.parametrize("path", CONSOLE, ids=_rel)
def test_console_commands_parse_and_name_existing_files(path: Path) -> None:
    for command in console_commands(path):
        for tokens in _segments(command):
            _check_segment(tokens)


def readme_runs() -> list[tuple[list[str], int, list[str]]]:
    """The README's ``$ kfio`` lines: ``(argv, exit code shown or 0, output lines shown)``."""
    runs = []
    for info, body in fences(ROOT / "README.md"):
        if info != "console" or "$ " not in body:
            continue
        for chunk in re.split(r"^\$ ", body, flags=re.M)[1:]:
            command, *shown = chunk.splitlines()
            code = 0
            if shown and re.fullmatch(r"exit \d+", shown[-1]):
                code = int(shown.pop()[5:])
            command = command.split(";")[0]
            argv = shlex.split(command, comments=True)
            assert Path(argv[0]).name == "kfio", command
            runs.append((argv[1:], code, shown))
    return runs


def _matches(shown: list[str], printed: list[str]) -> bool:
    """``printed`` equals ``shown``, where a line ``...`` stands for any number of lines."""
    pattern = "\n".join(".*?" if line == "..." else re.escape(line) for line in shown)
    return re.fullmatch(pattern, "\n".join(printed), flags=re.S) is not None


README_RUNS = readme_runs()


@pytest.mark.parametrize(("argv", "code", "shown"), README_RUNS, ids=[" ".join(argv) for argv, _, _ in README_RUNS])
def test_readme_commands_run_as_shown(argv, code, shown, capsys: pytest.CaptureFixture[str], monkeypatch) -> None:
    monkeypatch.chdir(ROOT)
    assert main(argv) == code
    printed = capsys.readouterr().out.rstrip("\n").splitlines()
    if shown:
        assert _matches(shown, printed), "\n".join(printed)
