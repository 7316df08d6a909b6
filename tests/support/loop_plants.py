"""Realistic loop requests: python-control plants of 8 to 10 states with ``dlqe``/``dlqr`` gains.

The plants a design team brings: a continuous plant sampled with ``control.c2d``,
the estimator gain of ``control.dlqe`` (predictor form, kfio's ``K``) and the
feedback gain of ``control.dlqr`` (kfio's ``L``).  Every float enters the
request as its shortest decimal text (``repr``), so the exact values of such a
loop have thousands of digits.  Deterministic: a seeded random plant with both
stable and unstable modes.
"""

from __future__ import annotations

from typing import Any

import control
import numpy as np


def _text(m: Any) -> list[list[str]]:
    return [[repr(float(x)) for x in row] for row in np.atleast_2d(np.asarray(m, dtype=float))]


def continuous_plant(n: int, m: int, p: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A seeded continuous plant ``(A, B, C)`` with one or two unstable modes (real parts up to 0.5)."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n)) / np.sqrt(n)
    shift = float(np.sort(np.linalg.eigvals(A).real)[-2]) - 0.3  # the top one or two modes unstable
    A = A - shift * np.eye(n)
    B = rng.normal(size=(n, m))
    C = rng.normal(size=(p, n))
    return A, B, C


def loop_plant_request(
    n: int,
    *,
    sensors: int = 1,
    inputs: int = 1,
    seed: int = 0,
    dt: float = 0.05,
    sensor_channel: dict[str, Any] | None = None,
    actuator_channel: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The loop request of an ``n``-state c2d plant with python-control's stationary gains.

    ``sensors > 1`` sends each output row in its own packet (``per_sensor``),
    every packet on ``sensor_channel`` (default Bernoulli 0.95); the actuator
    on ``actuator_channel`` (default Bernoulli 0.95).
    """
    Ac, Bc, Cc = continuous_plant(n, inputs, sensors, seed)
    plant = control.c2d(control.ss(Ac, Bc, Cc, np.zeros((sensors, inputs))), dt)
    A, B, C = np.asarray(plant.A), np.asarray(plant.B), np.asarray(plant.C)
    Q = 0.01 * np.eye(n)
    R = 0.04 * np.eye(sensors)
    K, _, _ = control.dlqe(A, np.eye(n), C, Q, R)  # estimator gain, predictor form: eig(A - K C)
    L, _, _ = control.dlqr(A, B, np.eye(n), 0.1 * np.eye(inputs))  # feedback gain: u = -L x_hat
    sensor = sensor_channel or {"model": "bernoulli", "arrival_probability": "0.95"}
    system: dict[str, Any] = {"A": _text(A), "B": _text(B), "C": _text(C), "Q": _text(Q), "R": _text(R)}
    if sensors > 1:
        names = [f"s{i}" for i in range(sensors)]
        system["sensors"] = [{"name": nm, "rows": [i]} for i, nm in enumerate(names)]
        channel: dict[str, Any] = {"model": "per_sensor", "channels": {nm: dict(sensor) for nm in names}}
    else:
        channel = dict(sensor)
    return {
        "system": system,
        "channel": channel,
        "actuator_channel": actuator_channel or {"model": "bernoulli", "arrival_probability": "0.95"},
        "controller": {"gains": {"estimator": _text(K), "feedback": _text(L)}, "form": "predictor"},
        "options": {"loop": {"protocol": "tcp", "on_loss": "zero"}},
    }


GE = {"model": "gilbert_elliott", "failure_rate": "0.05", "recovery_rate": "0.6"}


def ge_two_sensor_request(n: int = 10, seed: int = 0) -> dict[str, Any]:
    """The ``n``-state plant with two sensor packets and Gilbert-Elliott links on both sensors and the actuator."""
    return loop_plant_request(n, sensors=2, seed=seed, sensor_channel=GE, actuator_channel=GE)


__all__ = ["GE", "continuous_plant", "ge_two_sensor_request", "loop_plant_request"]
