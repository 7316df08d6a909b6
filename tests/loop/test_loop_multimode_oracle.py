"""kfio's exact loop analysis against an independent float model of the loop, on multi-mode loops.

The model (:mod:`support.loop_oracle`) is written from the loop's equations: the full joint
chain of every link (Bernoulli ones not averaged), the mode matrices from a plain step
function, ``sum p_ij (M_i kron M_i)`` on the full ``vec``, numpy's eigenvalues and a dense
solve of the coupled Lyapunov equations (Costa, Fragoso and Marques 2005, Ch. 3), critical
values by bisection on ``rho(T) < 1``.  kfio reduces the i.i.d. links, works on ``vech`` and
decides everything exactly over Q, so an agreement to 1e-9 is two routes meeting:

* verdict, spectral radius and stationary cost on hand-built loops (two Gilbert-Elliott links;
  two sensors on separate Gilbert-Elliott links), every form, protocol and loss rule, and on
  random loops;
* critical values (Bernoulli arrival probabilities, Gilbert-Elliott recovery rates) and the
  cut points of each link's range, to 1e-6; the failure rate's boundary, where kfio's exact
  verdict must flip; a UDP loop whose stable set is an interval that does not reach 1;
* kfio's definiteness decision on matrices ``L D L'`` whose inertia is that of ``D``
  (Sylvester's law), barely definite or barely indefinite;
* a Monte Carlo of the two-Gilbert-Elliott-link loop, TCP and UDP, against the exact cost.
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import replace
from fractions import Fraction as F

import flint
import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

from kfio.loop import analyze_loop, parse_loop_request
from kfio.loop._verdict import positive_definite

from support import loop_oracle as lo
from support.loop_oracle import Bernoulli, GilbertElliott, LoopSpec, MarkovLink, Sensor, mat

FORMS = ("predictor", "filter")
COMBOS = list(itertools.product(FORMS, ("tcp", "udp"), ("zero", "hold")))

#: A 2-state plant with one unstable mode, steady-state gains from the Riccati equations
#: (rounded to two decimals), the sensor and the actuator each on a Gilbert-Elliott link.
TWO_GE = LoopSpec(
    A=mat([["11/10", "1/5"], [0, "9/10"]]),
    B=mat([[0], [1]]),
    C=mat([[1, 0]]),
    Q=mat([[1, 0], [0, "1/2"]]),
    R=mat([["1/4"]]),
    K=mat([["49/50"], ["6/25"]]),
    L=mat([["31/25", "47/50"]]),
    sensors=(Sensor("s", (0,), GilbertElliott(F(1, 5), F(1, 2))),),
    actuator=GilbertElliott(F(1, 10), F(2, 3)),
    W=mat([[1, 0], [0, 1]]),
    U=mat([["1/2"]]),
)
#: The filter-form gain of the same plant: ``P C' (C P C' + R)^-1``.
TWO_GE_FILTER_K = mat([["17/20"], ["27/100"]])

#: The same plant measured by two sensors, each on its own Gilbert-Elliott link.
TWO_SENSORS = LoopSpec(
    A=TWO_GE.A,
    B=TWO_GE.B,
    C=mat([[1, 0], [0, 1]]),
    Q=TWO_GE.Q,
    R=mat([["1/4", 0], [0, "1/2"]]),
    K=mat([["23/25", "13/100"], ["1/100", "27/50"]]),
    L=TWO_GE.L,
    sensors=(
        Sensor("pos", (0,), GilbertElliott(F(1, 10), F(3, 5))),
        Sensor("vel", (1,), GilbertElliott(F(1, 5), F(1, 2))),
    ),
    actuator=Bernoulli(F(9, 10)),
    W=mat([[2, 0], [0, 1]]),
    U=mat([["1/3"]]),
)
TWO_SENSORS_FILTER_K = mat([["83/100", "1/100"], ["1/50", "3/5"]])

#: Two sensors and the actuator on Bernoulli links, UDP with hold: the sensor ``a``'s stable
#: set is not an interval, and the actuator's ``det(I - T(x))`` has a root inside an unstable
#: stretch (another eigenvalue of ``T`` crossing 1), which kfio must merge.
THREE_BERNOULLI = LoopSpec(
    A=mat([["11/10", "-1/10"], ["2/5", "9/10"]]),
    B=mat([[-1], ["3/5"]]),
    C=mat([["-1/2", -1], ["-3/10", "-7/10"]]),
    Q=mat([[1, 0], [0, "1/2"]]),
    R=mat([["1/4", 0], [0, "1/2"]]),
    K=mat([["-73/100", "-3/25"], ["-1/2", "-17/100"]]),
    L=mat([["-103/100", "-7/100"]]),
    sensors=(Sensor("a", (0,), Bernoulli(F(63, 100))), Sensor("b", (1,), Bernoulli(F(13, 20)))),
    actuator=Bernoulli(F(77, 100)),
    protocol="udp",
    on_loss="hold",
)

#: A scalar plant over two Gilbert-Elliott links, UDP with hold: ``det(I - T(x))`` of the
#: actuator's recovery rate has a root near 0.02 inside the unstable stretch (an eigenvalue of
#: ``T`` other than the spectral radius crossing 1) besides the critical value near 0.355.
SCALAR_MERGED = LoopSpec(
    A=mat([["6/5"]]),
    B=mat([[1]]),
    C=mat([[1]]),
    Q=mat([[1]]),
    R=mat([[1]]),
    K=mat([["1/2"]]),
    L=mat([["1/2"]]),
    sensors=(Sensor("s", (0,), GilbertElliott(F(1, 10), F(7, 10))),),
    actuator=GilbertElliott(F(1, 10), F(4, 5)),
    protocol="udp",
    on_loss="hold",
)

#: A scalar UDP loop whose estimator assumes the actuator arrives 3 times in 10: more arrivals
#: than that make the estimator's input model wrong enough to destabilize the loop.
UDP_INTERVAL = LoopSpec(
    A=mat([["11/10"]]),
    B=mat([[1]]),
    C=mat([[1]]),
    Q=mat([[1]]),
    R=mat([[1]]),
    K=mat([["9/10"]]),
    L=mat([["3/2"]]),
    sensors=(Sensor("s", (0,), GilbertElliott(F(1, 50), F(9, 10))),),
    actuator=Bernoulli(F(3, 10)),
    protocol="udp",
)


def with_form(spec: LoopSpec, form: str, filter_k, protocol: str, on_loss: str) -> LoopSpec:
    return replace(spec, form=form, K=filter_k if form == "filter" else spec.K, protocol=protocol, on_loss=on_loss)


def kfio_report(spec: LoopSpec, critical: bool = False) -> dict:
    """kfio's report on the JSON request of ``spec``, as the JSON door gives it."""
    return analyze_loop(parse_loop_request(lo.loop_request_json(spec)), critical=critical).to_dict()


def assert_same_analysis(spec: LoopSpec) -> lo.OracleResult:
    """Verdict identical, spectral radius to 1e-9, cost to 1e-9 relative (``None`` when unstable)."""
    want = lo.analyze(spec)
    # preconditions of the comparison: float64 resolves rho to 1e-10, and rho is not at 1
    assert want.radius_error < 1e-10 and abs(want.spectral_radius - 1) > 1e-6
    got = kfio_report(spec)
    assert got["verdict"] == want.verdict
    assert got["spectral_radius"] == pytest.approx(want.spectral_radius, rel=1e-9, abs=1e-12)
    if want.verdict == "stable":
        assert got["cost"] == pytest.approx(want.cost, rel=1e-9)
    else:
        assert got["cost"] is None
    return want


# -- the oracle itself against closed forms --------------------------------------------------------


def test_the_oracle_reproduces_the_scalar_closed_forms():
    """docs/loop.md's scalar loop: critical values 9/16 and 75/152 and the stationary error variance."""
    spec = LoopSpec(
        A=mat([["5/4"]]),
        B=mat([[1]]),
        C=mat([[1]]),
        Q=mat([[1]]),
        R=mat([["1/2"]]),
        K=mat([["1/2"]]),
        L=mat([["3/5"]]),
        sensors=(Sensor("s", (0,), Bernoulli(F(4, 5))),),
        actuator=Bernoulli(F(9, 10)),
        U=mat([["1/2"]]),
    )
    assert lo.critical_value(spec, 0, "arrival_probability") == pytest.approx(9 / 16, abs=1e-9)
    assert lo.critical_value(spec, 1, "arrival_probability") == pytest.approx(75 / 152, abs=1e-9)
    # with L = 0 the state is the open-loop plant and e = x - x_hat the fixed-gain error:
    # E e^2 = (q + lam k^2 r) / (1 - lam (a - k c)^2 - (1 - lam) a^2), a stable a keeps E x^2 finite
    a, k, r, lam = 0.9, 0.5, 0.5, 0.8
    open_loop = replace(spec, A=mat([["9/10"]]), L=mat([[0]]))
    res = lo.analyze(open_loop)
    X = sum(res.moments)
    e_var = X[0, 0] - 2 * X[0, 1] + X[1, 1]
    assert e_var == pytest.approx((1 + lam * k**2 * r) / (1 - lam * (a - k) ** 2 - (1 - lam) * a**2), rel=1e-12)
    assert X[0, 0] == pytest.approx(1 / (1 - a**2), rel=1e-12)


def test_the_oracles_chains_follow_the_channel_definitions():
    P, arrived = lo.link_chain(GilbertElliott(F(1, 5), F(1, 2)))
    # state = the last arrival; P(lost | arrived) = p, P(arrived | lost) = q
    assert arrived.tolist() == [0, 1]
    assert P == pytest.approx(np.array([[0.5, 0.5], [0.2, 0.8]]), abs=1e-15)
    assert lo.long_run_arrival(GilbertElliott(F(1, 5), F(1, 2))) == pytest.approx(0.5 / 0.7, rel=1e-14)
    table = (("00", F(1, 4)), ("01", F(1, 2)), ("10", F(3, 4)), ("11", F(9, 10)))
    P, arrived = lo.link_chain(MarkovLink(2, table))
    # state (g[t-1], g[t]) -> (g[t], g[t+1]); from "10" the next packet arrives with probability 3/4
    assert P[2] == pytest.approx(np.array([0.25, 0.75, 0, 0]), abs=1e-15) and arrived.tolist() == [0, 1, 0, 1]


# -- definiteness -------------------------------------------------------------------------------------


def _ldl(last: F, scale: F) -> flint.fmpq_mat:
    """``scale L D L'`` with ``D = diag(2, 1/3, 5/7, last)``: its inertia is that of ``D`` (Sylvester)."""
    L = [[F(1), 0, 0, 0], [F(3, 7), 1, 0, 0], [F(-2, 3), F(5, 11), 1, 0], [F(1, 2), F(-4, 9), F(7, 5), 1]]
    D = [F(2), F(1, 3), F(5, 7), last]
    X = [[scale * sum(L[i][k] * D[k] * L[j][k] for k in range(4)) for j in range(4)] for i in range(4)]
    return flint.fmpq_mat([[flint.fmpq(x.numerator, x.denominator) for x in row] for row in X])


@pytest.mark.parametrize("scale", [F(1), F(10) ** 40, F(1, 10**40)])
@pytest.mark.parametrize(
    "last,definite",
    [
        (F(1, 10**6), True),
        (F(-1, 10**6), False),
        (F(1, 10**14), True),
        (F(-1, 10**14), False),
        (F(1, 10**40), True),
        (F(-1, 10**40), False),
        (F(0), False),
    ],
)
def test_definiteness_of_barely_definite_and_barely_indefinite_matrices(last, definite, scale):
    assert positive_definite(_ldl(last, scale)) is definite


# -- verdict, spectral radius and cost -------------------------------------------------------------


@pytest.mark.parametrize("form,protocol,on_loss", COMBOS)
def test_two_gilbert_elliott_links_agree_with_the_oracle(form, protocol, on_loss):
    want = assert_same_analysis(with_form(TWO_GE, form, TWO_GE_FILTER_K, protocol, on_loss))
    assert want.verdict == "stable" and want.modes == 4


@pytest.mark.parametrize("form,protocol,on_loss", COMBOS)
def test_two_sensors_on_separate_gilbert_elliott_links_agree_with_the_oracle(form, protocol, on_loss):
    want = assert_same_analysis(with_form(TWO_SENSORS, form, TWO_SENSORS_FILTER_K, protocol, on_loss))
    assert want.verdict == "stable" and want.modes == 8


def test_unstable_multi_mode_loops_are_unstable_for_both():
    """Losses heavy enough to destabilize: kfio must not find a definite Lyapunov solution."""
    bursty = GilbertElliott(F(1, 2), F(1, 10))  # bursts of mean length 10: the unstable mode 11/10 grows
    for spec in (
        TWO_GE.with_link(0, bursty),
        TWO_GE.with_link(1, bursty),
        replace(TWO_SENSORS, actuator=GilbertElliott(F(3, 5), F(1, 10)), form="filter", K=TWO_SENSORS_FILTER_K),
    ):
        assert assert_same_analysis(spec).verdict == "unstable"


def _dec(x: float, den: int = 100) -> F:
    return F(int(round(float(x) * den)), den)


@functools.cache
def random_loop(seed: int) -> LoopSpec:
    """A random 2-state loop with steady-state gains (perturbed, rounded) and random links.

    Drawn again until float64 resolves its spectral radius to 1e-10 and ``rho`` is not
    within 1e-3 of 1 (the comparison's preconditions); some are unstable.
    """
    rng = np.random.default_rng(seed)
    for _ in range(50):
        spec = _draw(rng)
        res = lo.analyze(spec)
        if res.radius_error < 1e-10 and abs(res.spectral_radius - 1) > 1e-3:
            return spec
    raise AssertionError(f"seed {seed}: no well-conditioned loop in 50 draws")


def _draw(rng: np.random.Generator) -> LoopSpec:
    n, m = 2, 1
    p = int(rng.choice([1, 2]))
    while True:
        A = np.round(rng.uniform(-0.4, 0.4, (n, n)) + np.diag(rng.uniform(0.6, 1.25, n)), 1)
        B = np.round(rng.uniform(-1, 1, (n, m)), 1)
        C = np.round(rng.uniform(-1, 1, (p, n)), 1)
        controllable = np.linalg.matrix_rank(np.hstack([B, A @ B]), 1e-3) == n
        if controllable and np.linalg.matrix_rank(np.vstack([C, C @ A]), 1e-3) == n:
            break
    Q = np.diag(rng.choice([0.5, 1, 2], n))
    R = np.diag(rng.choice([0.25, 0.5, 1], p))
    form = str(rng.choice(FORMS))
    S = solve_discrete_are(A, B, np.eye(n), np.eye(m))
    Lg = np.linalg.solve(B.T @ S @ B + np.eye(m), B.T @ S @ A) * rng.uniform(0.7, 1.1)
    P = solve_discrete_are(A.T, C.T, Q, R)
    Kf = P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
    Kg = (Kf if form == "filter" else A @ Kf) * rng.uniform(0.7, 1.1)

    def link(memory: bool):
        kind = rng.choice(["bernoulli", "ge", "markov"] if memory else ["bernoulli", "ge"])
        if kind == "bernoulli":
            return Bernoulli(_dec(rng.uniform(0.6, 0.98)))
        if kind == "ge":
            return GilbertElliott(_dec(rng.uniform(0.02, 0.3)), _dec(rng.uniform(0.4, 0.95)))
        return MarkovLink(2, tuple((h, _dec(rng.uniform(0.5, 0.98))) for h in ("00", "01", "10", "11")))

    if p == 2 and rng.random() < 0.6:
        sensors = (Sensor("a", (0,), link(False)), Sensor("b", (1,), link(False)))
    else:
        sensors = (Sensor("s", tuple(range(p)), link(True)),)
    actuator = link(not any(isinstance(s.link, MarkovLink) for s in sensors))  # at most 16 joint modes

    def q(X: np.ndarray):
        return tuple(tuple(_dec(x) for x in row) for row in X)

    return LoopSpec(
        A=q(A),
        B=q(B),
        C=q(C),
        Q=q(Q),
        R=q(R),
        K=q(Kg),
        L=q(Lg),
        sensors=sensors,
        actuator=actuator,
        form=form,
        protocol=str(rng.choice(["tcp", "udp"])),
        on_loss=str(rng.choice(["zero", "hold"])),
        W=q(np.diag(rng.choice([1, 2], n))),
        U=q(np.diag([rng.choice([0, 0.5, 1])])),
    )


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(12))
def test_random_loops_agree_with_the_oracle(seed):
    assert_same_analysis(random_loop(seed))


@pytest.mark.slow
def test_the_random_loops_cover_both_verdicts_and_every_link_kind():
    specs = [random_loop(seed) for seed in range(12)]
    verdicts = {lo.analyze(s, with_cost=False).verdict for s in specs}
    kinds = {type(lk).__name__ for s in specs for lk in s.links}
    assert verdicts == {"stable", "unstable"}
    assert kinds == {"Bernoulli", "GilbertElliott", "MarkovLink"}
    assert {(s.form, s.protocol, s.on_loss) for s in specs} >= {("filter", "tcp", "hold"), ("predictor", "udp", "hold")}


# -- critical values ----------------------------------------------------------------------------------


def _parameter(link) -> str:
    return "arrival_probability" if isinstance(link, Bernoulli) else "recovery_rate"


def _assert_pieces_agree(spec: LoopSpec, index: int, parameter: str, crit: dict, grid: int) -> None:
    pieces = lo.stable_intervals(spec, index, parameter, grid)
    kfio_pieces = [(i["from"], i["to"], i["verdict"]) for i in crit["intervals"]]
    assert [v for *_, v in kfio_pieces] == [v for *_, v in pieces], (index, kfio_pieces, pieces)
    for (a, b, _), (c, e, _) in zip(kfio_pieces, pieces):
        assert a == pytest.approx(c, abs=1e-6) and b == pytest.approx(e, abs=1e-6)
    if parameter != "failure_rate":  # the left end of the stable piece that reaches 1
        want = pieces[-1][0] if pieces[-1][2] == "stable" else None
        if want is None:
            assert crit["value"] is None
        else:
            assert crit["value"] == pytest.approx(want, abs=1e-6)


def assert_critical_values_agree(spec: LoopSpec, grid: int = 20) -> list[dict]:
    """Each link's critical value and the cut points of its range against bisection, to 1e-6.

    Returns kfio's entries for the links' arrival probabilities and recovery rates (a Markov
    link's entry has no value), in link order; a failure-rate entry, when kfio gives one, has
    its cut points compared too.
    """
    by_parameter = {c["parameter"]: c for c in kfio_report(spec, critical=True)["critical_values"]}
    main = []
    for index, link in enumerate(spec.links):
        if isinstance(link, MarkovLink):  # no parameter to vary: the entry says so, without a value
            assert by_parameter[lo.link_pointer(spec, index)]["value"] is None
            main.append(by_parameter[lo.link_pointer(spec, index)])
            continue
        names = [_parameter(link)] + (["failure_rate"] if isinstance(link, GilbertElliott) else [])
        for parameter in names:
            crit = by_parameter.get(f"{lo.link_pointer(spec, index)}/{parameter}")
            if crit is None and parameter == "failure_rate":
                continue
            assert crit is not None, (index, parameter, sorted(by_parameter))
            _assert_pieces_agree(spec, index, parameter, crit, grid)
            if parameter != "failure_rate":
                main.append(crit)
    return main


@pytest.mark.parametrize("form,protocol,on_loss", [("predictor", "tcp", "zero"), ("filter", "udp", "hold")])
def test_gilbert_elliott_recovery_rates_against_bisection(form, protocol, on_loss):
    got = assert_critical_values_agree(with_form(TWO_GE, form, TWO_GE_FILTER_K, protocol, on_loss))
    # both links need some recovery: the critical values are inside (0, 1), not at an end
    assert all(0.1 < c["value"] < 0.6 for c in got)


@pytest.mark.slow
@pytest.mark.parametrize("form,protocol,on_loss", [("filter", "tcp", "hold"), ("predictor", "udp", "zero")])
def test_gilbert_elliott_recovery_rates_against_bisection_other_combinations(form, protocol, on_loss):
    assert_critical_values_agree(with_form(TWO_GE, form, TWO_GE_FILTER_K, protocol, on_loss))


@pytest.mark.slow
def test_two_sensor_links_and_a_bernoulli_actuator_against_bisection():
    got = assert_critical_values_agree(TWO_SENSORS)
    assert got[0]["value"] > 0.1 and got[2]["value"] > 0.1  # the position sensor and the actuator matter


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(12))
def test_random_loops_critical_values_against_bisection(seed):
    assert_critical_values_agree(random_loop(seed))


@pytest.mark.slow
def test_cut_points_of_a_range_that_is_not_an_interval_and_a_merged_root():
    """The sensor ``a``: stable, unstable, stable; the actuator: a root inside the unstable stretch."""
    got = assert_critical_values_agree(THREE_BERNOULLI, grid=40)
    assert [i["verdict"] for i in got[0]["intervals"]] == ["stable", "unstable", "stable"]


def test_an_unstable_stretch_holding_another_root_is_one_interval():
    got = assert_critical_values_agree(SCALAR_MERGED)
    assert [i["verdict"] for i in got[1]["intervals"]] == ["unstable", "stable"]
    assert 0.3 < got[1]["value"] < 0.4


@pytest.mark.parametrize("index", [0, 1])
def test_gilbert_elliott_failure_rate_boundary_flips_kfios_exact_verdict(index):
    """kfio reports no failure-rate critical value: the oracle's bisected one must separate its verdicts.

    With recovery 9/50, just above ``1 - 1/(11/10)^2``, frequent failures destabilize the loop.
    """
    spec = TWO_GE.with_link(index, GilbertElliott(F(1, 20), F(9, 50)))
    pieces = lo.stable_intervals(spec, index, "failure_rate", grid=20)
    assert [v for *_, v in pieces] == ["stable", "unstable"]
    edge = pieces[0][1]
    assert 0.05 < edge < 0.95
    for delta, verdict in ((-1e-4, "stable"), (1e-4, "unstable")):
        value = F(round((edge + delta) * 10**7), 10**7)
        link = replace(spec.links[index], failure_rate=value)
        assert kfio_report(spec.with_link(index, link))["verdict"] == verdict


def test_a_udp_stable_set_that_does_not_reach_one():
    """With ``nubar`` fixed by the estimator, too many actuator arrivals destabilize too: no critical value."""
    got = assert_critical_values_agree(UDP_INTERVAL, grid=40)
    actuator = got[-1]
    assert [i["verdict"] for i in actuator["intervals"]] == ["unstable", "stable", "unstable"]
    assert actuator["value"] is None
    left, right = actuator["intervals"][1]["from"], actuator["intervals"][1]["to"]
    assert left < 0.3 < right < 1  # the request's own point is stable
    assert kfio_report(UDP_INTERVAL)["verdict"] == "stable"


# -- Monte Carlo --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "form,protocol,on_loss", [("predictor", "tcp", "zero"), ("filter", "udp", "hold"), ("filter", "tcp", "hold")]
)
def test_monte_carlo_cost_of_two_gilbert_elliott_links(form, protocol, on_loss):
    """The simulated loop's average cost within 4 standard errors of kfio's exact cost (seeded)."""
    spec = with_form(TWO_GE, form, TWO_GE_FILTER_K, protocol, on_loss)
    exact = kfio_report(spec)["cost"]
    mean, se = lo.simulate_cost(spec, runs=4000, steps=400, seed=11)
    assert se < 0.03 * exact  # tight enough to tell the planted bugs' costs apart
    assert abs(mean - exact) < 4 * se, (mean, se, exact)
