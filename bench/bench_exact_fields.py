"""Worker CPU per uncached ``analyze`` request: exact radicals against the old ``nsimplify`` route.

    python bench/bench_exact_fields.py [--repeats 20]

``critical_arrival_probability_exact`` and ``sigma_exact``
were recognised from floats by ``sympy.nsimplify`` (PSLQ), which was wrong at
ordinary inputs and the main cost of an uncached analysis.  The baseline below
re-installs that route (the code as it was) by monkeypatching, in the same
process, and both are timed with ``time.process_time`` (CPU of this process,
i.e. of one worker) on the same requests.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from fractions import Fraction
from pathlib import Path
from typing import Any

import mpmath
import sympy

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from kfio import analyze, load_request  # noqa: E402
from kfio.stability import _verdict  # noqa: E402

REQUESTS = {
    "scalar 559/134": {"A": [["559/134"]], "C": [[1]]},
    "seed 2x2": {"A": [[1.25, 0], [1, 1.1]], "C": [[1, 1]]},
    "mirror pair": {"A": [["7/3", 0], [0, "-7/3"]], "C": [[1, 1]]},
    "Sinopoli et al. (2004) 3x3": {"A": [[1.25, 1, 0], [0, 0.9, 7], [0, 0, 0.6]], "C": [[1, 0, 2]]},
}


class _OldSigma:
    """What ``_sigma_exact_text`` returned before: ``nsimplify`` of prod (1 - lambda_g)^e_g."""

    def __init__(self, text: str, value: float) -> None:
        self._text, self._value = text, value

    def text(self) -> str:
        return self._text

    def approx(self, digits: int) -> float:
        return self._value


def _old_sigma_exact(res: Any, c: Fraction | None) -> _OldSigma | None:
    if res.bernoulli_exponents is None:
        return None
    lam = _CURRENT["lambda"]
    expr = sympy.Integer(1)
    for e in res.bernoulli_exponents:
        expr *= (1 - sympy.Rational(lam.numerator, lam.denominator)) ** sympy.Rational(e.numerator, e.denominator)
    return _OldSigma(str(sympy.nsimplify(expr)), res.sigma)


def _old_critical_probability(blocks: Any, display: Any = None) -> tuple[float | None, str | None, list[str]]:
    best = None
    for b in blocks:
        if b.rate is None:
            continue
        share = b.bernoulli_blind_fraction[0]
        if share == 0:
            return None, None, []
        beta = b.modulus_sq_expr if b.modulus_sq_expr is not None else sympy.Float(b.modulus**2, 30)
        expr = 1 - beta ** (-1 / sympy.Rational(share.numerator, share.denominator))
        expr = sympy.nsimplify(expr) if beta.is_Rational else expr
        val = mpmath.mpf(str(sympy.N(expr, 40)))
        if best is None or val > best[0]:
            best = (val, expr)
    if best is None or best[0] < 0:
        return 0.0, "0", []
    return float(best[0]), str(best[1]), []


_CURRENT: dict[str, Fraction] = {}


def _cpu(system: dict, lam: Fraction, repeats: int) -> float:
    """Median CPU seconds of ``analyze`` over ``repeats`` distinct probabilities (no cache can help)."""
    times = []
    for k in range(repeats):
        p = lam + Fraction(k, 10**6)
        _CURRENT["lambda"] = p
        req = load_request(
            json.dumps(
                {
                    "system": system,
                    "channel": {"model": "bernoulli", "arrival_probability": f"{p.numerator}/{p.denominator}"},
                }
            )
        )
        t0 = time.process_time()
        analyze(req)
        times.append(time.process_time() - t0)
    times.sort()
    return times[len(times) // 2]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=20)
    args = ap.parse_args()
    new_sigma, new_crit = _verdict._sigma_exact, _verdict._critical_probability
    print(f"{'request':<16} {'nsimplify ms':>13} {'exact ms':>9} {'ratio':>6}")
    for name, system in REQUESTS.items():
        lam = Fraction(600053, 1000000)
        _verdict._sigma_exact, _verdict._critical_probability = new_sigma, new_crit
        _cpu(system, lam, 2)  # warm caches of SymPy itself
        new = _cpu(system, lam, args.repeats)
        _verdict._sigma_exact, _verdict._critical_probability = _old_sigma_exact, _old_critical_probability
        old = _cpu(system, lam, args.repeats)
        _verdict._sigma_exact, _verdict._critical_probability = new_sigma, new_crit
        print(f"{name:<16} {old * 1e3:13.1f} {new * 1e3:9.1f} {old / new:6.1f}")


if __name__ == "__main__":
    main()
