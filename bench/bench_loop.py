"""Seconds to decide a loop exactly: ``n = 4``, two sensors, Gilbert-Elliott links on both sides.

    python bench/bench_loop.py

A fourth-order plant (two coupled carts, one unstable mode) sampled at 0.1 s,
python-control's ``dlqe`` and ``dlqr`` gains (17 significant digits each, read
exactly), each sensor and the actuator on its own Gilbert-Elliott link.  The
joint chain has 8 modes, the loop state 8 coordinates, so the second-moment
operator has size ``8 * 8 * 9 / 2 = 288``.  Printed: the CPU seconds of the
exact verdict with the exact stationary cost (FLINT over Q), of the float
margin alone (full ``vec`` operator, size ``8 * 64 = 512``, numpy
eigenvalues), and of two exact baselines: one coupled Lyapunov solve over Q
with SymPy's sparse ``DomainMatrix`` (kfio solves two right-hand sides, the
certificate and the moments), and the characteristic polynomial of the
operator with FLINT (the textbook route to ``rho``), with the ratios.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import control  # noqa: E402

import kfio  # noqa: E402
from kfio.loop import (  # noqa: E402
    analyze_loop,
    loop_request,  # noqa: E402
    parse_loop_request,
)
from kfio.loop._mjls import loop_mjls  # noqa: E402
from kfio.loop._operator import float_operator, noise_vector, operator_matrix  # noqa: E402


def plant_request() -> dict:
    A = [[0, 1, 0, 0], [-2, -0.1, 2, 0], [0, 0, 0, 1], [2, 0, -2 + 2.5, -0.1]]
    sys_c = control.ss(A, [[0], [1], [0], [0]], [[1, 0, 0, 0], [0, 0, 1, 0]], [[0], [0]])
    plant = control.c2d(sys_c, 0.1)
    Q, R = 0.01 * np.eye(4), 0.04 * np.eye(2)
    K, _, _ = control.dlqe(plant.A, np.eye(4), plant.C, Q, R)
    L, _, _ = control.dlqr(plant.A, plant.B, np.eye(4), np.array([[0.1]]))
    ge = kfio.gilbert_elliott
    return loop_request(
        kfio.System(A=plant.A, C=plant.C, Q=Q, R=R, sensors={"cart1": [0], "cart2": [1]}),
        feedback=L,
        estimator=K,
        channel=kfio.per_sensor(
            {"cart1": ge(failure_rate=0.05, recovery_rate=0.6), "cart2": ge(failure_rate=0.1, recovery_rate=0.5)}
        ),
        actuator_channel=ge(failure_rate=0.05, recovery_rate=0.7),
        B=plant.B,
    )


def sympy_baseline(sys) -> float:
    """The same exact solve of ``(I - T) Y = rhs`` with SymPy's DomainMatrix over QQ."""
    from sympy import QQ
    from sympy.polys.matrices import DomainMatrix

    T = operator_matrix(sys)
    rhs = noise_vector(sys)
    size = T.nrows()
    rows = [
        [QQ(int(T[i, j].p), int(T[i, j].q)) * -1 + (QQ(1) if i == j else QQ(0)) for j in range(size)]
        for i in range(size)
    ]
    b = [[QQ(int(rhs[i, 0].p), int(rhs[i, 0].q))] for i in range(size)]
    t0 = time.process_time()
    DomainMatrix(rows, (size, size), QQ).lu_solve(DomainMatrix(b, (size, 1), QQ))
    return time.process_time() - t0


def flint_charpoly(sys) -> float:
    """The characteristic polynomial of the same operator over Q (FLINT): the textbook exact route."""
    T = operator_matrix(sys)
    t0 = time.process_time()
    T.charpoly()
    return time.process_time() - t0


def main() -> None:
    body = plant_request()
    req = parse_loop_request(body)
    t0 = time.process_time()
    report = analyze_loop(req, critical=False)
    exact_s = time.process_time() - t0
    sys_ = loop_mjls(req)
    t0 = time.process_time()
    T = float_operator(sys_)
    rho = float(np.max(np.abs(np.linalg.eigvals(T))))
    float_s = time.process_time() - t0
    print(
        f"operator size {report.operator_size} ({report.modes} modes), verdict {report.verdict}, "
        f"rho {report.spectral_radius:.6f} (float check {rho:.6f}), exact cost {report.cost:.6g}"
    )
    print(f"exact verdict + exact cost (FLINT): {exact_s:8.3f} s CPU")
    print(f"float margin alone (numpy):         {float_s:8.3f} s CPU  ratio exact/float {exact_s / float_s:8.1f}")
    base = sympy_baseline(sys_)
    print(f"one exact solve with SymPy (QQ):    {base:8.3f} s CPU  ratio SymPy/kfio {base / exact_s:8.2f}")
    cp = flint_charpoly(sys_)
    print(f"characteristic polynomial (FLINT):  {cp:8.3f} s CPU  ratio charpoly/kfio {cp / exact_s:8.2f}")


if __name__ == "__main__":
    main()
