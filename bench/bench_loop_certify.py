"""CPU seconds of the certified loop verdict and cost enclosure at sizes the exact route cannot reach.

    python bench/bench_loop_certify.py [--exact]

The loop of ``tests/support/loop_plants.py``: a seeded 10-state plant sampled by ``control.c2d``,
python-control's ``dlqe``/``dlqr`` gains, two sensor packets and Gilbert-Elliott links on both
sensors and the actuator (8 channel modes, loop state 20, operator size 1680).  Printed, in CPU
seconds of this process:

* **certified**: :func:`kfio.loop._certify.certify` (float Lyapunov solve, Perron candidates,
  interval proofs of the verdict, enclosures of ``rho`` and of the cost), plus building the loop;
* **numpy**: the plain float solve of the same operator, numpy's dense ``I - T`` and
  ``np.linalg.solve`` for the Lyapunov and noise right-hand sides, no proof (the naive baseline);
* the ratio of the two;
* the exact route's time for the 8-state Bernoulli loop's verdict and cost, and for smaller plants
  (``--exact`` also tries the 10-state loop exactly; minutes).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from kfio.loop import decide, loop_mjls, parse_loop_request  # noqa: E402
from kfio.loop._certify import certify  # noqa: E402
from kfio.loop._cost import stationary_cost  # noqa: E402
from kfio.loop._operator import float_operator, noise_vector, vech_index  # noqa: E402
from tests.support.loop_plants import ge_two_sensor_request, loop_plant_request  # noqa: E402


def timed(fn):
    t0 = time.process_time()
    out = fn()
    return out, time.process_time() - t0


def numpy_solve(sys_):
    T = float_operator(sys_)
    size = T.shape[0]
    ident = np.tile([1.0 if a == b else 0.0 for a, b in vech_index(sys_.d)], sys_.modes)
    noise = noise_vector(sys_)
    rhs = np.column_stack([ident, [float(noise[i, 0]) for i in range(size)]])
    return np.linalg.solve(np.eye(size) - T, rhs)


def exact(sys_):
    dec = decide(sys_, route="exact")
    return dec, stationary_cost(sys_, dec.moments) if dec.moments is not None else None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exact", action="store_true", help="also run the exact route on the 10-state GE loop")
    parser.add_argument("--repeat", type=int, default=3, help="runs of each timing (the minimum is printed)")
    args = parser.parse_args(argv)
    req = parse_loop_request(ge_two_sensor_request(10))
    runs = [timed(lambda: certify(loop_mjls(req))) for _ in range(args.repeat)]
    cert, t_cert = min(runs, key=lambda r: r[1])
    sys_ = loop_mjls(req)
    t_np = min(timed(lambda: numpy_solve(sys_))[1] for _ in range(args.repeat))
    size = sys_.modes * len(vech_index(sys_.d))
    lo, hi = cert.cost_enclosure or (None, None)
    rlo, rhi = cert.radius_enclosure or (None, None)
    print(f"10-state plant, two sensor packets, three Gilbert-Elliott links: {sys_.modes} modes, operator size {size}")
    print(f"  verdict {cert.verdict} ({cert.certificate})")
    print(f"  rho in [{float(rlo):.10f}, {float(rhi):.10f}], float {cert.radius:.10f}")
    print(f"  cost in [{float(lo):.12g}, {float(hi):.12g}] (width {float(hi - lo):.2e})")
    print(f"  certified verdict + enclosures: {t_cert:.3f} s CPU")
    print(f"  numpy float solve, no proof:     {t_np:.3f} s CPU")
    print(f"  ratio certified / numpy:         {t_cert / t_np:.2f}")
    for n in (4, 6, 8):
        s = loop_mjls(parse_loop_request(loop_plant_request(n)))
        (_, cost), t_exact = timed(lambda s=s: exact(s))
        c, t_c = timed(lambda s=s: certify(s))
        size_n = s.modes * len(vech_index(s.d))
        inside = c.cost_enclosure is not None and c.cost_enclosure[0] <= cost <= c.cost_enclosure[1]
        print(
            f"{n}-state Bernoulli loop (size {size_n}): exact verdict + cost {t_exact:.3f} s, "
            f"certified {t_c:.3f} s, ratio {t_exact / t_c:.1f}; exact cost inside the enclosure: {inside}"
        )
    if args.exact:
        (_, cost), t_exact = timed(lambda: exact(sys_))
        print(f"exact route on the 10-state GE loop: {t_exact:.1f} s; inside: {lo <= cost <= hi}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
