"""CPU of ``is_psd``'s exact route against the size bound that replaced its 10 s clock.

    python bench/bench_validation.py

Near-singular 40 x 40 PSD matrices ``B B^T`` (``B`` 40 x 39 random integers,
so the float filter cannot decide and the exact route runs) with entries sized
so that Hadamard's bound of the matrix grows to the limit
``MAX_EXACT_PSD_BITS``; each CPU time is printed with its ratio to the
smallest matrix, measured in the same run.  Above the limit the request is
refused, deterministically.
"""

from __future__ import annotations

import random
import sys
import time
from fractions import Fraction
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from kfio.model._request import MAX_EXACT_PSD_BITS, _float_filter, hadamard_bits, is_psd  # noqa: E402


def near_singular(n: int, bits: int, seed: int = 0) -> tuple[tuple[Fraction, ...], ...]:
    rng = random.Random(seed)
    B = [[rng.randrange(-(2**bits), 2**bits) for _ in range(n - 1)] for _ in range(n)]
    return tuple(tuple(Fraction(sum(B[i][k] * B[j][k] for k in range(n - 1))) for j in range(n)) for i in range(n))


def main() -> None:
    print(f"limit MAX_EXACT_PSD_BITS = {MAX_EXACT_PSD_BITS}")
    print(f"{'entry bits':>10} {'Hadamard bits':>14} {'filter':>7} {'CPU s':>7} {'ratio':>6}")
    base = None
    for bits in (8, 32, 96, 190, 370):
        M = near_singular(40, bits)
        h = hadamard_bits(M)
        if h > MAX_EXACT_PSD_BITS:
            print(f"{bits:>10} {h:>14} (above the limit: refused)")
            continue
        t0 = time.process_time()
        ok = is_psd(M, strict=False)
        dt = time.process_time() - t0
        assert ok
        base = base or dt
        print(f"{bits:>10} {h:>14} {str(_float_filter(M)):>7} {dt:7.3f} {dt / base:6.1f}")


if __name__ == "__main__":
    main()
