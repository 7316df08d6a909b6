"""Seconds to compute the polynomial det(I - T(x)) behind a loop's exact critical values.

    python bench/bench_loop_critical.py

A second-order plant with Gilbert-Elliott links on both sides (``on_loss: hold``, UDP-like: loop
state 6, 4 channel modes, operator size 84), and the fourth-order plant of ``bench_loop.py`` with
one Gilbert-Elliott sensor packet and a Gilbert-Elliott actuator (operator size 144).  Printed:
CPU seconds of the multimodular pencil determinant kfio uses (:mod:`kfio.loop._pencil`) and, at
size 84, of the rational route it replaced (``A0^-1 T1`` over Q and its characteristic
polynomial, FLINT), with the ratio; the two polynomials are checked proportional.  The rational
route at size 144 took about 250 s on the development machine and is not run here.
"""

from __future__ import annotations

import sys
import time
from fractions import Fraction
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_loop  # noqa: E402

import kfio  # noqa: E402
from kfio.loop import loop_mjls, loop_request, parse_loop_request  # noqa: E402
from kfio.loop._critical import det_polynomial, det_polynomial_rational, parameter_of  # noqa: E402
from kfio.loop._operator import float_operator  # noqa: E402


def small_request():
    ge = kfio.gilbert_elliott
    return parse_loop_request(
        loop_request(
            kfio.System(
                A=[["1.1", "0.3"], ["0", "0.9"]], C=[["1", "0.5"]], Q=[["0.2", "0"], ["0", "0.1"]], R=[["0.3"]]
            ),
            feedback=[["0.4712345678", "0.2234567891"]],
            estimator=[["0.6123456789"], ["0.1334567891"]],
            channel=ge(failure_rate="0.05", recovery_rate="0.6"),
            actuator_channel=ge(failure_rate="0.1", recovery_rate="0.7"),
            B=[["0"], ["1"]],
            options={"protocol": "udp", "on_loss": "hold"},
        )
    )


def large_request():
    body = bench_loop.plant_request()
    body["channel"] = {"model": "gilbert_elliott", "failure_rate": 0.05, "recovery_rate": 0.6}
    body["system"].pop("sensors")
    return parse_loop_request(body)


def timed(fn):
    t0 = time.process_time()
    out = fn()
    return out, time.process_time() - t0


def main() -> None:
    for name, req, baseline in (("n = 2, hold, UDP", small_request(), True), ("n = 4", large_request(), False)):
        _, at = parameter_of("/actuator_channel", req.actuator)

        def build(x, req=req, at=at):
            return loop_mjls(req, {"/actuator_channel": at(x)})

        size = float_operator(build(Fraction(1, 2))).shape[0]
        fast, fast_s = timed(lambda: det_polynomial(build))
        line = f"{name}: operator size {size}, degree {fast.degree()}: multimodular {fast_s:8.2f} s CPU"
        if baseline:
            slow, slow_s = timed(lambda: det_polynomial_rational(build))
            same = fast * slow.coeffs()[-1] == slow * fast.coeffs()[-1]
            line += f", rational route {slow_s:8.2f} s CPU, ratio rational/multimodular {slow_s / fast_s:6.1f}, proportional {same}"
        print(line)


if __name__ == "__main__":
    main()
