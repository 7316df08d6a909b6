"""The multimodular det(I - T(x)) of the critical values against two independent exact routes.

kfio.loop._pencil computes det(P - x Q) prime by prime and rebuilds it by the Chinese remainder
theorem up to a proven coefficient bound; here it must equal (a) FLINT's integer determinant at
integer points and (b) the rational route (A0^-1 T1 over Q, its characteristic polynomial) up to a
constant, on loops whose operators have memory (Gilbert-Elliott links on both sides).
"""

from __future__ import annotations

from fractions import Fraction

import flint
import pytest

import kfio
from kfio.loop import loop_mjls, loop_request, parse_loop_request
from kfio.loop._critical import det_polynomial, det_polynomial_rational, parameter_of
from kfio.loop._operator import operator_matrix
from kfio.loop._pencil import det_pencil, det_polynomial_of, integer_pencil


def _request(on_loss: str = "zero", protocol: str = "tcp"):
    system = kfio.System(
        A=[["1.1", "0.3"], ["0", "0.9"]], C=[["1", "0.5"]], Q=[["0.2", "0"], ["0", "0.1"]], R=[["0.3"]]
    )
    ge = kfio.gilbert_elliott
    tree = loop_request(
        system,
        feedback=[["0.47", "0.22"]],
        estimator=[["0.61"], ["0.13"]],
        channel=ge(failure_rate="0.05", recovery_rate="0.6"),
        actuator_channel=ge(failure_rate="0.1", recovery_rate="0.7"),
        B=[["0"], ["1"]],
        options={"protocol": protocol, "on_loss": on_loss},
    )
    return parse_loop_request(tree)


@pytest.mark.parametrize("pointer", ["/channel", "/actuator_channel"])
def test_pencil_determinant_equals_flint_integer_determinant_at_points(pointer):
    req = _request()
    ch = req.channel if pointer == "/channel" else req.actuator
    _, at = parameter_of(pointer, ch)
    T0 = operator_matrix(loop_mjls(req, {pointer: at(Fraction(1, 3))}))
    T1 = (operator_matrix(loop_mjls(req, {pointer: at(Fraction(2, 3))})) - T0) * 3
    P, Q = integer_pencil(T0, T1)
    poly = det_pencil(P, Q)
    assert poly is not None and poly.degree() >= 1
    for x in (-2, 0, 1, 5):
        assert poly(x) == (P - x * Q).det()


@pytest.mark.parametrize("on_loss,protocol", [("zero", "tcp"), pytest.param("hold", "udp", marks=pytest.mark.slow)])
def test_multimodular_and_rational_routes_give_the_same_polynomial(on_loss, protocol):
    req = _request(on_loss, protocol)
    for pointer, ch in (("/channel", req.channel), ("/actuator_channel", req.actuator)):
        _, at = parameter_of(pointer, ch)

        def build(x, pointer=pointer, at=at):
            return loop_mjls(req, {pointer: at(x)})

        fast, slow = det_polynomial(build), det_polynomial_rational(build)
        assert fast is not None and slow is not None and fast.degree() == slow.degree() >= 1
        assert fast * slow.coeffs()[-1] == slow * fast.coeffs()[-1]  # proportional


def test_a_singular_p_is_reported_and_the_caller_shifts_x():
    P = flint.fmpz_mat(2, 2, [1, 2, 2, 4])
    Q = flint.fmpz_mat(2, 2, [1, 0, 0, 0])
    assert det_pencil(P, Q) is None  # det(P - x Q) = -4 x, but P itself is singular
    T0 = flint.fmpq_mat(2, 2, [0, 0, 0, 1])
    T1 = flint.fmpq_mat(2, 2, [0, 0, 0, 1])
    poly = det_polynomial_of(T0, T1)  # det(I - T0 - x T1) = -x
    assert poly is not None and poly.degree() == 1 and poly(0) == 0 and poly(1) != 0
