"""A downstream user's typed code: ``mypy --strict`` must pass on it (tests/typing/test_typed_api.py)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np

import kfio


def critical_probability(a: Fraction) -> Fraction:
    """The exact critical arrival probability of a scalar plant, as a ``Fraction``."""
    report: kfio.StabilityReport = kfio.analyze(kfio.System(A=[[a]], C=[[1]]), kfio.bernoulli("1/2"))
    value = report.exact_of("critical_arrival_probability")
    if not isinstance(value, Fraction):
        raise TypeError(f"not rational: {value}")
    return value


def is_stable(A: kfio.MatrixLike, p: kfio.NumberLike) -> bool:
    """Whether the filter of ``A`` observed through ``C = I`` is stable at arrival probability ``p``."""
    n = len(np.asarray(A))
    system = kfio.System(A=A, C=np.eye(n), Q=np.eye(n), R=np.eye(n))
    verdict: kfio.Verdict = kfio.analyze(system, kfio.bernoulli(p), budget=30).verdict
    return verdict == kfio.Verdict.STABLE


def critical_as_float(report: kfio.StabilityReport) -> float | None:
    """The critical arrival probability as a float, whether it is rational or algebraic."""
    exact: Fraction | kfio.ExactReal | None = report.exact_of("critical_arrival_probability")
    return None if exact is None else float(exact)


def request_file(system: kfio.System) -> kfio.Request:
    """The validated request that the JSON route builds for the same values."""
    return kfio.build_request(system, kfio.gilbert_elliott(failure_rate=0.1, recovery_rate="3/5"), budget=10)


def loop_needs(feedback: kfio.MatrixLike, estimator: kfio.MatrixLike) -> tuple[kfio.Verdict, float | None]:
    """A scalar loop's verdict and its critical actuator arrival probability, gains named by role."""
    plant = kfio.System(A=[[1.25]], C=[[1]], Q=[[1]], R=[["1/2"]])
    report = kfio.loop(
        plant,
        B=[[1]],
        feedback=feedback,
        estimator=estimator,
        form="predictor",
        channel=kfio.bernoulli(0.8),
        actuator_channel=kfio.bernoulli(0.9),
        options={"protocol": "tcp"},
        budget=30,
    )
    verdict: kfio.Verdict = report.verdict
    return verdict, report.critical_actuator_arrival_probability


def every_command(plant: kfio.System, sweep_file: str, check_file: str) -> list[object]:
    """Each public function once, with one budget keyword, its typed result and an exact value."""
    channel = kfio.bernoulli("3/5")
    bounds: kfio.BoundsReport = kfio.bounds(plant, channel, budget=30)
    sim: kfio.SimulationReport = kfio.simulate(plant, channel, steps=5, trajectories=10, seed=1, budget=30)
    exact: kfio.FiniteHorizonReport = kfio.expected_covariance(plant, channel, 2, budget=kfio.Budget(seconds=30))
    fitted: kfio.FitReport = kfio.fit("0110111011", model="bernoulli", budget=5)
    swept: kfio.SweepResult = kfio.sweep(sweep_file, engine="serial", budget=60)
    checked: kfio.CheckResult = kfio.check(check_file, workers=1, budget=60)
    first: Fraction | kfio.ExactReal | None = swept.rows[0].exact_of("critical_arrival_probability")
    measured: Fraction | kfio.ExactReal | None = checked.outcomes[0].exact_of("measured")
    status: str = checked.status
    return [bounds.verdict, sim.mean_diverged_at, exact.mean_trace, fitted.channel, first, measured, status]


if __name__ == "__main__":
    print(critical_probability(Fraction(5, 4)), is_stable([[1.25]], 0.5), request_file(kfio.System(A=[[2]], C=[[1]])))
