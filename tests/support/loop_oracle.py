"""An independent float model of a loop closed over lossy links, for the loop tests.

The loop of Schenato, Sinopoli, Franceschetti, Poolla and Sastry (2007), Sec. II, with
fixed gains, written from its equations (docs/loop.md, "The model") and never from
kfio's code::

    x[t+1] = A x[t] + B a[t] + w[t],    y[t] = C x[t] + v[t],    (w, v) ~ N(0, diag(Q, R))
    innovation   i[t] = Gamma[t] (y[t] - C x_hat[t])        (lost sensor rows add nothing)
    filter form  x_f[t] = x_hat[t] + K i[t],  u[t] = -L x_f[t],  x_hat[t+1] = A x_f[t] + B a_hat[t]
    predictor    u[t] = -L x_hat[t],          x_hat[t+1] = A x_hat[t] + B a_hat[t] + K i[t]
    applied      a[t] = u[t] if the actuator packet arrives, else 0 (zero) or a[t-1] (hold)
    estimator    a_hat[t] = a[t] (tcp);  nubar u[t] (udp, zero);  nubar u[t] + (1 - nubar) a_hat[t-1] (udp, hold)

``nubar`` is the actuator link's long-run arrival rate at the request (the estimator's
design: it stays fixed when a critical value varies the link).

Every link is a Markov chain whose state holds its latest arrivals, the last one being
the packet of time ``t`` (a Bernoulli or Gilbert-Elliott link remembers one arrival, a
Markov link of order ``nu`` its ``nu`` last).  The route differs from kfio's on purpose:

* the **full joint chain** of all links, Bernoulli ones included (no averaging);
* the mode matrices from one plain step function of the equations above, applied to the
  unit vectors, for ``z = (x, x_hat[, a[t-1]][, a_hat[t-1]])``;
* the second-moment operator ``T(X)_j = sum_i p_ij M_i X_i M_i'`` as the dense matrix
  ``p_ij (M_i kron M_i)`` on the full ``vec`` (size ``N d^2``, not ``vech``), its spectral
  radius by numpy's eigenvalues (Costa, Fragoso and Marques 2005, Ch. 3 and Thm 3.9);
* the stationary moments from ``X_j = sum_i p_ij (M_i X_i M_i' + pi_i G_i Sigma G_i')``
  and the cost ``sum_i tr(W X_i^xx) + tr(U F_i X_i F_i') + pi_i tr(U E_i Sigma E_i')``
  with ``a = F_i z + E_i n`` in mode ``i``;
* critical values by plain bisection on ``rho(T) < 1``.

:func:`simulate_cost` is a third route: a seeded Monte Carlo of the same equations,
vectorized over independent runs, written separately from :func:`mode_maps`.

Every loop request of the tests is built by :func:`loop_request_json`, the one place that
knows the request's field names.
"""

from __future__ import annotations

import contextlib
import ctypes
import itertools
from dataclasses import dataclass, replace
from fractions import Fraction
from pathlib import Path
from typing import Iterator, Sequence, Union

import numpy as np

Matrix = tuple[tuple[Fraction, ...], ...]


def frac(x: int | str | Fraction) -> Fraction:
    """An exact number from an int, a Fraction or a text such as ``"3/4"`` (floats are refused)."""
    if isinstance(x, float):
        raise TypeError("loop oracle numbers are exact: pass a Fraction, an int or a text")
    return Fraction(x)


def mat(rows: Sequence[Sequence[int | str | Fraction]]) -> Matrix:
    """A matrix of exact numbers, as nested tuples."""
    return tuple(tuple(frac(x) for x in row) for row in rows)


def text(x: Fraction) -> str:
    """The exact text of a number for a request: ``"3/4"``, ``"-2"``."""
    return str(x.numerator) if x.denominator == 1 else f"{x.numerator}/{x.denominator}"


def _json_matrix(m: Matrix) -> list[list[str]]:
    return [[text(x) for x in row] for row in m]


def _f(m: Matrix) -> np.ndarray:
    return np.array([[float(x) for x in row] for row in m], dtype=float).reshape(len(m), len(m[0]) if m else 0)


def _openblas() -> tuple[ctypes._CFuncPtr, ctypes._CFuncPtr] | None:
    """The thread-count getter and setter of numpy's bundled OpenBLAS, when the wheel ships one."""
    folder = Path(np.__file__).resolve().parent.parent / "numpy.libs"
    for lib in sorted(folder.glob("*openblas*")) if folder.is_dir() else []:
        handle = ctypes.CDLL(str(lib))
        for prefix, suffix in (("scipy_openblas", "64_"), ("openblas", "64_"), ("openblas", "")):
            get = getattr(handle, f"{prefix}_get_num_threads{suffix}", None)
            put = getattr(handle, f"{prefix}_set_num_threads{suffix}", None)
            if get is not None and put is not None:
                get.restype = ctypes.c_int
                return get, put
    return None


_BLAS = _openblas()


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run numpy's linear algebra on one thread, then restore the thread count.

    The oracle solves many small dense eigenproblems; on cores shared with other
    processes a threaded OpenBLAS spends most of its time waiting for its own
    threads (measured: 20 times slower for a 144 x 144 matrix on two busy cores).
    """
    if _BLAS is None:
        yield
        return
    get, put = _BLAS
    before = get()
    put(1)
    try:
        yield
    finally:
        put(before)


# -- links -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Bernoulli:
    """I.i.d. arrivals with probability ``arrival_probability``."""

    arrival_probability: Fraction

    def json(self) -> dict:
        return {"model": "bernoulli", "arrival_probability": text(self.arrival_probability)}

    def arrival_law(self) -> tuple[int, dict[tuple[int, ...], float]]:
        """Memory (one arrival) and P(next packet arrives | remembered arrivals)."""
        lam = float(self.arrival_probability)
        return 1, {(0,): lam, (1,): lam}


@dataclass(frozen=True)
class GilbertElliott:
    """``failure_rate`` p = P(lost | previous arrived), ``recovery_rate`` q = P(arrived | previous lost)."""

    failure_rate: Fraction
    recovery_rate: Fraction

    def json(self) -> dict:
        return {
            "model": "gilbert_elliott",
            "failure_rate": text(self.failure_rate),
            "recovery_rate": text(self.recovery_rate),
        }

    def arrival_law(self) -> tuple[int, dict[tuple[int, ...], float]]:
        return 1, {(1,): 1.0 - float(self.failure_rate), (0,): float(self.recovery_rate)}


@dataclass(frozen=True)
class MarkovLink:
    """Order ``nu``: ``table["01"]`` is P(arrival | g[t-2] = 0, g[t-1] = 1), oldest first."""

    order: int
    table: tuple[tuple[str, Fraction], ...]

    def json(self) -> dict:
        return {
            "model": "markov",
            "order": self.order,
            "arrival_probability": {h: text(p) for h, p in self.table},
        }

    def arrival_law(self) -> tuple[int, dict[tuple[int, ...], float]]:
        return self.order, {tuple(int(c) for c in h): float(p) for h, p in self.table}


Link = Union[Bernoulli, GilbertElliott, MarkovLink]


def link_chain(link: Link) -> tuple[np.ndarray, np.ndarray]:
    """The link's chain: transition matrix over remembered histories, and the arrival of each state.

    A state is the tuple of the last ``memory`` arrivals, oldest first; its last entry is the
    packet of the current step.  From ``h`` the next packet arrives with probability
    ``P(1 | h)`` and the state becomes ``h[1:] + (g,)``.
    """
    memory, law = link.arrival_law()
    states = list(itertools.product((0, 1), repeat=memory))
    index = {h: k for k, h in enumerate(states)}
    P = np.zeros((len(states), len(states)))
    for h in states:
        P[index[h], index[h[1:] + (1,)]] += law[h]
        P[index[h], index[h[1:] + (0,)]] += 1.0 - law[h]
    return P, np.array([h[-1] for h in states])


def stationary_law(P: np.ndarray) -> np.ndarray:
    """The probability vector ``pi`` with ``pi P = pi`` (least squares with ``sum pi = 1``)."""
    N = P.shape[0]
    lhs = np.vstack([P.T - np.eye(N), np.ones((1, N))])
    rhs = np.zeros(N + 1)
    rhs[-1] = 1.0
    pi, *_ = np.linalg.lstsq(lhs, rhs, rcond=None)
    return np.asarray(pi)


def long_run_arrival(link: Link) -> float:
    """The fraction of the link's packets that arrive in the long run."""
    P, arrived = link_chain(link)
    return float(stationary_law(P) @ arrived)


# -- the loop -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Sensor:
    """One sensor packet: the rows of ``C`` it carries and its link."""

    name: str
    rows: tuple[int, ...]
    link: Link


@dataclass(frozen=True)
class LoopSpec:
    """A loop with fixed gains: ``K`` the estimator gain, ``u = -L x_hat`` (docs/loop.md)."""

    A: Matrix
    B: Matrix
    C: Matrix
    Q: Matrix
    R: Matrix
    K: Matrix
    L: Matrix
    sensors: tuple[Sensor, ...]
    actuator: Link
    form: str = "predictor"
    protocol: str = "tcp"
    on_loss: str = "zero"
    W: Matrix | None = None
    U: Matrix | None = None

    @property
    def n(self) -> int:
        return len(self.A)

    @property
    def m(self) -> int:
        return len(self.B[0])

    @property
    def p(self) -> int:
        return len(self.C)

    @property
    def links(self) -> tuple[Link, ...]:
        """Every link: the sensors' in order, then the actuator's."""
        return tuple(s.link for s in self.sensors) + (self.actuator,)

    def with_link(self, index: int, link: Link) -> LoopSpec:
        """The same loop with link ``index`` (of :attr:`links`) replaced."""
        if index == len(self.sensors) or index == -1:
            return replace(self, actuator=link)
        sensors = list(self.sensors)
        sensors[index] = replace(sensors[index], link=link)
        return replace(self, sensors=tuple(sensors))


def link_pointer(spec: LoopSpec, index: int) -> str:
    """The JSON pointer of link ``index``'s channel in :func:`loop_request_json`."""
    if index in (len(spec.sensors), -1):
        return "/actuator_channel"
    if len(spec.sensors) == 1:
        return "/channel"
    return f"/channel/channels/{spec.sensors[index].name}"


def loop_request_json(spec: LoopSpec) -> dict:
    """The kfio loop request of ``spec``: the only function of the tests that spells its fields."""
    system: dict = {
        "A": _json_matrix(spec.A),
        "B": _json_matrix(spec.B),
        "C": _json_matrix(spec.C),
        "Q": _json_matrix(spec.Q),
        "R": _json_matrix(spec.R),
    }
    if len(spec.sensors) == 1:
        if sorted(spec.sensors[0].rows) != list(range(spec.p)):
            raise ValueError("one sensor packet carries every row of C")
        channel = spec.sensors[0].link.json()
    else:
        system["sensors"] = [{"name": s.name, "rows": list(s.rows)} for s in spec.sensors]
        channel = {"model": "per_sensor", "channels": {s.name: s.link.json() for s in spec.sensors}}
    body: dict = {
        "system": system,
        "channel": channel,
        "actuator_channel": spec.actuator.json(),
        "controller": {
            "gains": {"estimator": _json_matrix(spec.K), "feedback": _json_matrix(spec.L)},
            "form": spec.form,
        },
        "options": {"loop": {"protocol": spec.protocol, "on_loss": spec.on_loss}},
    }
    cost = {}
    if spec.W is not None:
        cost["W"] = _json_matrix(spec.W)
    if spec.U is not None:
        cost["U"] = _json_matrix(spec.U)
    if cost:
        body["cost"] = cost
    return body


def state_size(spec: LoopSpec) -> int:
    """``d``: ``x`` and ``x_hat``, plus ``a[t-1]`` (hold), plus ``a_hat[t-1]`` (hold and udp)."""
    extra = 0 if spec.on_loss == "zero" else (spec.m if spec.protocol == "tcp" else 2 * spec.m)
    return 2 * spec.n + extra


def step(
    spec: LoopSpec, z: np.ndarray, w: np.ndarray, v: np.ndarray, gamma: np.ndarray, arrived: int, nubar: float
) -> tuple[np.ndarray, np.ndarray]:
    """One step of the loop equations (module docstring): ``(z[t+1], a[t])`` from ``z[t]``, ``w``, ``v``."""
    A, B, C, K, L = (_f(x) for x in (spec.A, spec.B, spec.C, spec.K, spec.L))
    n, m = spec.n, spec.m
    x, x_hat = z[:n], z[n : 2 * n]
    hold = spec.on_loss == "hold"
    a_prev = z[2 * n : 2 * n + m] if hold else np.zeros(m)
    belief_prev = z[2 * n + m : 2 * n + 2 * m] if hold and spec.protocol == "udp" else np.zeros(m)
    innovation = gamma * (C @ x + v - C @ x_hat)
    x_used = x_hat + K @ innovation if spec.form == "filter" else x_hat
    u = -L @ x_used
    a = u if arrived else a_prev  # a_prev is zero unless the actuator holds
    if spec.protocol == "tcp":
        a_hat = a
    else:
        a_hat = nubar * u + (1 - nubar) * belief_prev
    x_next = A @ x + B @ a + w
    if spec.form == "filter":
        x_hat_next = A @ x_used + B @ a_hat
    else:
        x_hat_next = A @ x_hat + B @ a_hat + K @ innovation
    parts = [x_next, x_hat_next]
    if hold:
        parts.append(a)
        if spec.protocol == "udp":
            parts.append(a_hat)
    return np.concatenate(parts), a


def mode_maps(
    spec: LoopSpec, gamma: np.ndarray, arrived: int, nubar: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(M, G, F, E)``: ``z[t+1] = M z + G n`` and ``a[t] = F z + E n``, ``n = (w, v)``, by unit vectors."""
    d, n, p = state_size(spec), spec.n, spec.p
    zeros = np.zeros
    cols_z = [step(spec, e, zeros(n), zeros(p), gamma, arrived, nubar) for e in np.eye(d)]
    cols_w = [step(spec, zeros(d), e, zeros(p), gamma, arrived, nubar) for e in np.eye(n)]
    cols_v = [step(spec, zeros(d), zeros(n), e, gamma, arrived, nubar) for e in np.eye(p)]
    M = np.column_stack([c[0] for c in cols_z])
    F = np.column_stack([c[1] for c in cols_z]).reshape(spec.m, d)
    G = np.column_stack([c[0] for c in cols_w + cols_v])
    E = np.column_stack([c[1] for c in cols_w + cols_v]).reshape(spec.m, n + p)
    return M, G, F, E


@dataclass(frozen=True)
class OracleResult:
    """What the oracle computes for one loop.

    ``verdict`` is ``stable`` iff ``spectral_radius < 1`` (floats: no boundary); ``cost`` and
    the mode-wise stationary moments ``X_j = E[z z' 1{theta = j}]`` are ``None`` unless
    stable; ``modes`` counts the joint chain's states; ``radius_error`` bounds the float error
    of ``spectral_radius`` to first order (``nan`` when only the radius was asked for).
    """

    spectral_radius: float
    verdict: str
    cost: float | None
    modes: int
    moments: tuple[np.ndarray, ...] | None
    radius_error: float


def joint_chain(spec: LoopSpec) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """The joint chain of all links (independent, so the product chain) and each mode's arrivals by link."""
    chains = [link_chain(lk) for lk in spec.links]
    states = list(itertools.product(*(range(P.shape[0]) for P, _ in chains)))
    N = len(states)
    P = np.ones((N, N))
    for a, sa in enumerate(states):
        for b, sb in enumerate(states):
            for (Pk, _), i, j in zip(chains, sa, sb):
                P[a, b] *= Pk[i, j]
    arrivals = [tuple(int(arr[i]) for (_, arr), i in zip(chains, s)) for s in states]
    return P, arrivals


def _modes(spec: LoopSpec, nubar: float | None) -> tuple[np.ndarray, list[tuple[np.ndarray, ...]]]:
    if nubar is None:
        nubar = long_run_arrival(spec.actuator) if spec.protocol == "udp" else 1.0
    P, arrivals = joint_chain(spec)
    maps = []
    for arr in arrivals:
        gamma = np.zeros(spec.p)
        for sensor, g in zip(spec.sensors, arr[:-1]):
            gamma[list(sensor.rows)] = g
        maps.append(mode_maps(spec, gamma, arr[-1], nubar))
    return P, maps


def second_moment_operator(P: np.ndarray, Ms: Sequence[np.ndarray]) -> np.ndarray:
    """``T`` on the stacked full ``vec X_j``: block ``(j, i)`` is ``p_ij (M_i kron M_i)``."""
    N, d = len(Ms), Ms[0].shape[0]
    T = np.zeros((N * d * d, N * d * d))
    for i in range(N):
        MM = np.kron(Ms[i], Ms[i])
        for j in range(N):
            T[j * d * d : (j + 1) * d * d, i * d * d : (i + 1) * d * d] = P[i, j] * MM
    return T


def analyze(spec: LoopSpec, nubar: float | None = None, with_cost: bool = True) -> OracleResult:
    """Spectral radius, verdict and stationary cost of the loop (module docstring).

    ``nubar`` overrides the estimator's idea of the actuator rate (UDP); by default it is
    the long-run arrival rate of ``spec.actuator``.
    """
    with one_blas_thread():
        return _analyze(spec, nubar, with_cost)


def _analyze(spec: LoopSpec, nubar: float | None, with_cost: bool) -> OracleResult:
    P, maps = _modes(spec, nubar)
    Ms = [mp[0] for mp in maps]
    N, d = len(Ms), Ms[0].shape[0]
    T = second_moment_operator(P, Ms)
    values, right = np.linalg.eig(T)
    top = int(np.argmax(np.abs(values)))
    rho = float(np.abs(values[top]))
    verdict = "stable" if rho < 1 else "unstable"
    if not with_cost:
        return OracleResult(rho, verdict, None, N, None, float("nan"))
    error = _radius_error(T, values[top], right[:, top])
    if verdict != "stable":
        return OracleResult(rho, verdict, None, N, None, error)
    pi = stationary_law(P)
    Sigma = np.zeros((spec.n + spec.p, spec.n + spec.p))
    Sigma[: spec.n, : spec.n] = _f(spec.Q)
    Sigma[spec.n :, spec.n :] = _f(spec.R)
    forcing = np.zeros(N * d * d)
    for j in range(N):
        acc = sum(P[i, j] * pi[i] * (maps[i][1] @ Sigma @ maps[i][1].T) for i in range(N))
        forcing[j * d * d : (j + 1) * d * d] = np.asarray(acc).reshape(-1)
    x = np.linalg.solve(np.eye(N * d * d) - T, forcing)
    X = [x[j * d * d : (j + 1) * d * d].reshape(d, d) for j in range(N)]
    W = _f(spec.W) if spec.W is not None else np.eye(spec.n)
    U = _f(spec.U) if spec.U is not None else np.zeros((spec.m, spec.m))
    cost = 0.0
    for i in range(N):
        _, G, F, E = maps[i]
        cost += np.trace(W @ X[i][: spec.n, : spec.n])
        cost += np.trace(U @ F @ X[i] @ F.T) + pi[i] * np.trace(U @ E @ Sigma @ E.T)
    return OracleResult(rho, verdict, float(cost), N, tuple(X), error)


def _radius_error(T: np.ndarray, value: complex, right: np.ndarray) -> float:
    """First-order bound on the float error of the top eigenvalue: ``kappa eps ||T||_F``.

    ``kappa = ||x|| ||y|| / |y^H x|`` with ``x``, ``y`` its right and left eigenvectors
    (Wilkinson's condition number): a backward error ``eps ||T||`` of the eigenvalue solver
    moves a simple eigenvalue by at most about that much.
    """
    left_values, left = np.linalg.eig(T.T)
    y = left[:, int(np.argmin(np.abs(left_values - value)))]
    kappa = np.linalg.norm(right) * np.linalg.norm(y) / abs(np.vdot(y, right))
    return float(kappa * np.finfo(float).eps * np.linalg.norm(T))


# -- critical values by bisection ---------------------------------------------------------------


def with_parameter(link: Link, parameter: str, value: Fraction) -> Link:
    """``link`` with one parameter set: ``arrival_probability``, ``failure_rate`` or ``recovery_rate``."""
    return replace(link, **{parameter: value})  # type: ignore[arg-type]


def radius_at(spec: LoopSpec, index: int, parameter: str, value: float, nubar: float | None) -> float:
    """``rho(T)`` with link ``index``'s ``parameter`` at ``value`` (``nubar`` fixed)."""
    link = with_parameter(spec.links[index], parameter, Fraction(value))
    return analyze(spec.with_link(index, link), nubar=nubar, with_cost=False).spectral_radius


def stable_intervals(
    spec: LoopSpec, index: int, parameter: str, grid: int = 40, tol: float = 1e-11
) -> list[tuple[float, float, str]]:
    """The parameter's range ``(0, 1)`` cut where ``rho(T) = 1``: ``(from, to, verdict)`` pieces.

    The verdict is sampled at ``grid`` points ``(k + 1/2) / grid`` and each change of verdict
    between neighbours is located by plain bisection on ``rho(T) < 1`` to ``tol``; pieces
    narrower than the grid's step may be missed (the tests' loops have none).  For a UDP loop
    the estimator's ``nubar`` stays that of the request's actuator link.
    """
    nubar = long_run_arrival(spec.actuator) if spec.protocol == "udp" else None
    xs = [(k + 0.5) / grid for k in range(grid)]
    stable = [radius_at(spec, index, parameter, x, nubar) < 1 for x in xs]
    cuts = []
    for k in range(grid - 1):
        if stable[k] != stable[k + 1]:
            lo, hi = xs[k], xs[k + 1]
            while hi - lo > tol:
                mid = (lo + hi) / 2
                if (radius_at(spec, index, parameter, mid, nubar) < 1) == stable[k]:
                    lo = mid
                else:
                    hi = mid
            cuts.append((lo + hi) / 2)
    edges = [0.0, *cuts, 1.0]
    verdicts = [stable[0]] + [not stable[0] if k % 2 == 0 else stable[0] for k in range(len(cuts))]
    return [(edges[k], edges[k + 1], "stable" if verdicts[k] else "unstable") for k in range(len(edges) - 1)]


def critical_value(spec: LoopSpec, index: int, parameter: str, grid: int = 40) -> float | None:
    """The left end of the stable piece that reaches 1 (arrival probability, recovery rate); ``None`` if 1 is unstable."""
    pieces = stable_intervals(spec, index, parameter, grid)
    return pieces[-1][0] if pieces[-1][2] == "stable" else None


# -- Monte Carlo ----------------------------------------------------------------------------------


def _sqrt_psd(S: np.ndarray) -> np.ndarray:
    vals, vecs = np.linalg.eigh(S)
    return np.asarray(vecs * np.sqrt(np.clip(vals, 0, None)))


def simulate_cost(spec: LoopSpec, runs: int, steps: int, seed: int, burn_in: int | None = None) -> tuple[float, float]:
    """Monte Carlo of the stationary cost: ``(mean, standard error)`` over independent runs.

    ``runs`` loops are simulated side by side from ``z = 0``, each link started in a state
    drawn from its stationary law; one sample is a run's average of ``x' W x + a' U a`` over
    the steps after ``burn_in`` (default half), so the samples are independent and the
    standard error is ``std / sqrt(runs)``.  The equations are written here once more, on
    batches, apart from :func:`step`.
    """
    with one_blas_thread():
        return _simulate_cost(spec, runs, steps, seed, burn_in)


def _simulate_cost(spec: LoopSpec, runs: int, steps: int, seed: int, burn_in: int | None) -> tuple[float, float]:
    rng = np.random.default_rng(seed)
    A, B, C, K, L = (_f(x) for x in (spec.A, spec.B, spec.C, spec.K, spec.L))
    W = _f(spec.W) if spec.W is not None else np.eye(spec.n)
    U = _f(spec.U) if spec.U is not None else np.zeros((spec.m, spec.m))
    Qh, Rh = _sqrt_psd(_f(spec.Q)), _sqrt_psd(_f(spec.R))
    n, m, p = spec.n, spec.m, spec.p
    burn_in = steps // 2 if burn_in is None else burn_in
    udp, hold, filt = spec.protocol == "udp", spec.on_loss == "hold", spec.form == "filter"
    nubar = long_run_arrival(spec.actuator) if udp else 1.0
    chains = [link_chain(lk) for lk in spec.links]
    link_state = [rng.choice(P.shape[0], size=runs, p=stationary_law(P).clip(0)) for P, _ in chains]
    row_owner = np.zeros(p, dtype=int)
    for k, sensor in enumerate(spec.sensors):
        row_owner[list(sensor.rows)] = k
    x, x_hat = np.zeros((runs, n)), np.zeros((runs, n))
    held, belief = np.zeros((runs, m)), np.zeros((runs, m))
    total = np.zeros(runs)
    for t in range(steps):
        got = [arr[s] for (_, arr), s in zip(chains, link_state)]
        gamma = np.stack([got[row_owner[r]] for r in range(p)], axis=1)
        act = got[-1][:, None].astype(bool)
        y = x @ C.T + rng.standard_normal((runs, p)) @ Rh.T
        innovation = gamma * (y - x_hat @ C.T)
        estimate = x_hat + innovation @ K.T if filt else x_hat
        u = -estimate @ L.T
        a = np.where(act, u, held if hold else 0.0)
        if not udp:
            a_hat = a
        elif hold:
            a_hat = nubar * u + (1 - nubar) * belief
        else:
            a_hat = nubar * u
        if t >= burn_in:
            total += np.einsum("ri,ij,rj->r", x, W, x) + np.einsum("ri,ij,rj->r", a, U, a)
        w = rng.standard_normal((runs, n)) @ Qh.T
        x_next = x @ A.T + a @ B.T + w
        if filt:
            x_hat = estimate @ A.T + a_hat @ B.T
        else:
            x_hat = x_hat @ A.T + a_hat @ B.T + innovation @ K.T
        x, held, belief = x_next, a, a_hat
        link_state = [
            _next_state(P, s, rng) for (P, _), s in zip(chains, link_state)
        ]  # the chain moves after the packet of time t is used
    samples = total / (steps - burn_in)
    return float(samples.mean()), float(samples.std(ddof=1) / np.sqrt(runs))


def _next_state(P: np.ndarray, s: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    cumulative = np.cumsum(P[s], axis=1)
    draw = rng.random(s.size)[:, None]
    return np.minimum((draw >= cumulative).sum(axis=1), P.shape[0] - 1)


__all__ = [
    "Bernoulli",
    "GilbertElliott",
    "LoopSpec",
    "MarkovLink",
    "OracleResult",
    "Sensor",
    "analyze",
    "critical_value",
    "frac",
    "joint_chain",
    "link_chain",
    "link_pointer",
    "long_run_arrival",
    "loop_request_json",
    "mat",
    "mode_maps",
    "one_blas_thread",
    "simulate_cost",
    "stable_intervals",
    "step",
]
