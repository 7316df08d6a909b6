"""The checkout's folders, for tests that read shipped files (wherever the test file sits under tests/)."""

from __future__ import annotations

from pathlib import Path

#: The repository root (the folder of pyproject.toml).
ROOT = Path(__file__).resolve().parents[2]
#: The shipped example requests.
EXAMPLES = ROOT / "examples"
