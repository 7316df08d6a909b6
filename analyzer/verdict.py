"""Seed 001, Theorem 1: the exact stability verdict (work in progress)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .model import Request


@dataclass(frozen=True)
class StabilityReport:
    verdict: str

    def to_dict(self) -> dict[str, Any]:
        return {"verdict": self.verdict}

    def summary(self) -> str:
        return self.verdict


def analyze(request: Request) -> StabilityReport:
    raise NotImplementedError("analysis is being written")
