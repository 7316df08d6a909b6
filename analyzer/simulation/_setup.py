"""What a simulation needs, validated once: limits, options and float matrices.

Shared by :mod:`kfio.simulation._simulate` (Monte Carlo) and
:mod:`kfio.simulation._finite_horizon` (exact enumeration).  ``request.options
["simulate"]`` is the raw JSON object of the request; it is validated here and
nowhere else, and every error names its field as a JSON pointer under
``/options/simulate``.

Options
-------
``steps``
    Horizon ``T`` of the Monte Carlo run (default 200, at most
    ``SimulationLimits.max_steps``).
``trajectories``
    Number ``M`` of independent trajectories (at least 2).  Default: 10 000,
    or fewer if ``steps * 10 000`` would exceed ``max_trajectory_steps``
    (with the default limits and 200 steps: 5 000).
``seed``
    Seed of ``numpy.random.Generator(PCG64(seed))`` (default 0): the same
    seed gives the same report, bit for bit.
``P0``
    Initial error covariance ``P_0 = P_{0|-1}`` (symmetric positive
    semidefinite, exact).  Default ``Q``: the covariance one open-loop step
    after perfect knowledge (``Phi_0(0) = Q``), which has the units of the
    state, unlike the identity.  Rohr, Marelli and Fu (2014), Theorem 1 holds for every
    ``P_0 >= 0``, so the verdict does not depend on this choice.
``exact_steps``
    Horizon of the exact enumeration of ``E[P_t]`` (Rohr, Marelli and Fu (2014), eq. (7)); the
    number of arrival sequences ``2^(m * exact_steps)`` (``m`` packets) is
    capped by ``max_sequences``.
``initial_channel``
    ``"stationary"`` (default): each packet's channel history before ``t = 0``
    is drawn from the stationary distribution of its Markov chain, so the
    arrival process is stationary from the first step.  ``"all_arrived"`` /
    ``"all_lost"``: every packet starts with a history of ``nu`` arrivals /
    losses.
``percentiles``
    Fixed at ``[50, 90, 99]``; accepted only with that value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..errors import InvalidInput, LimitExceeded
from ..model import (
    DEFAULT_LIMITS,
    OPTION_KEYS,
    Matrix,
    Packet,
    Request,
    check_symmetric,
    is_psd,
    option_field,
    option_group,
    packets_of,
    parse_integer,
    parse_matrix,
    to_float,
)

OPTIONS_FIELD = "/options/simulate"
_STEPS = option_field("simulate", "steps")
_TRAJECTORIES = option_field("simulate", "trajectories")
_SEED = option_field("simulate", "seed")
_EXACT_STEPS = option_field("simulate", "exact_steps")
_INITIAL = option_field("simulate", "initial_channel")
PERCENTILES: tuple[int, ...] = tuple(option_field("simulate", "percentiles").default)
INITIAL_CHANNELS = _INITIAL.enum
_KEYS = OPTION_KEYS["simulate"]


@dataclass(frozen=True)
class SimulationLimits:
    """Size limits of simulation requests (a deployment may pass its own).

    Attributes
    ----------
    max_steps:
        Longest Monte Carlo horizon.
    max_trajectory_steps:
        Cap on ``steps * trajectories`` (the work of one request).
    max_sequences:
        Cap on the arrival sequences ``2^(m T)`` the exact enumeration visits.
    max_batch_floats:
        Cap on ``trajectories * n^2``, the floats held for the covariances.
    default_steps, default_trajectories:
        Values used when the request gives none.
    """

    max_steps: int = int(_STEPS.maximum or 0)
    max_trajectory_steps: int = 1_000_000
    max_sequences: int = 1 << 20
    max_batch_floats: int = 1 << 25
    default_steps: int = int(_STEPS.default)
    default_trajectories: int = int(_TRAJECTORIES.default)


DEFAULT_SIMULATION_LIMITS = SimulationLimits()


@dataclass(frozen=True, eq=False)
class SimSystem:
    """The plant as float64 arrays plus its packets (read-only arrays)."""

    A: np.ndarray
    C: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    packets: tuple[Packet, ...]

    @property
    def n(self) -> int:
        return int(self.A.shape[0])

    def rows_of(self, arrived: tuple[bool, ...]) -> tuple[int, ...]:
        """Rows of ``C`` carried by the packets flagged in ``arrived`` (sorted)."""
        return tuple(sorted(r for pk, a in zip(self.packets, arrived) if a for r in pk.rows))

    def row_mask(self, arrived: np.ndarray) -> np.ndarray:
        """Per-row 0/1 mask ``(..., p)`` from per-packet arrivals ``(..., m)``."""
        mask = np.zeros(arrived.shape[:-1] + (self.C.shape[0],))
        for s, pk in enumerate(self.packets):
            mask[..., list(pk.rows)] = arrived[..., s : s + 1]
        return mask


@dataclass(frozen=True, eq=False)
class SimulateOptions:
    """Validated ``options.simulate`` (see the module docstring)."""

    steps: int
    trajectories: int
    seed: int
    P0: np.ndarray
    P0_is_default: bool
    exact_steps: int | None
    initial_channel: str


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def sim_system(request: Request) -> SimSystem:
    """Float arrays of the plant; ``Q`` and ``R`` are required to simulate.

    Raises
    ------
    InvalidInput
        ``/system/Q`` or ``/system/R`` missing.
    """
    sysm = request.system
    if sysm.Q is None:
        raise InvalidInput("/system/Q", "Q (process noise covariance) is required to simulate the Riccati recursion")
    if sysm.R is None:
        raise InvalidInput(
            "/system/R", "R (measurement noise covariance) is required to simulate the Riccati recursion"
        )
    return SimSystem(
        A=_readonly(to_float(sysm.A)),
        C=_readonly(to_float(sysm.C)),
        Q=_readonly(to_float(sysm.Q)),
        R=_readonly(to_float(sysm.R)),
        packets=packets_of(request),
    )


def _int_option(raw: Mapping[str, Any], key: str, default: int | None, hi: int | None = None) -> int | None:
    """The integer option ``key`` in its table range (``hi``, when given, a deployment's own upper end)."""
    if key not in raw:
        return default
    f = option_field("simulate", key)
    upper = hi if hi is not None else None if f.maximum is None else int(f.maximum)
    return parse_integer(raw[key], f.pointer, int(f.minimum or 0), upper, key)


def _parse_p0(raw: Any, n: int) -> Matrix:
    where = f"{OPTIONS_FIELD}/P0"
    m = parse_matrix(raw, where, "P0", DEFAULT_LIMITS, DEFAULT_LIMITS.max_states, DEFAULT_LIMITS.max_states)
    check_symmetric(m, where, "P0", n)
    if not is_psd(m, strict=False, where=where):
        raise InvalidInput(where, "P0 must be positive semidefinite")
    return m


def max_exact_steps(n_packets: int, limits: SimulationLimits = DEFAULT_SIMULATION_LIMITS) -> int:
    """Largest horizon ``T`` with ``2^(m T) <= max_sequences``."""
    return int(math.floor(math.log2(limits.max_sequences))) // max(n_packets, 1)


def check_exact_steps(steps: int, n_packets: int, limits: SimulationLimits, field: str) -> None:
    """Raise :class:`LimitExceeded` when ``2^(m * steps)`` sequences exceed the cap."""
    if steps > max_exact_steps(n_packets, limits):
        raise LimitExceeded(
            field,
            f"exact enumeration over {steps} steps visits 2^{n_packets * steps} arrival sequences "
            f"({n_packets} packet(s)); the limit is {limits.max_sequences} "
            f"(at most {max_exact_steps(n_packets, limits)} steps)",
        )


def parse_options(request: Request, limits: SimulationLimits = DEFAULT_SIMULATION_LIMITS) -> SimulateOptions:
    """Validate ``request.options["simulate"]``.

    Raises
    ------
    InvalidInput
        Unknown key, wrong type, out-of-range value; the field is
        ``/options/simulate/<key>``.
    LimitExceeded
        ``steps``, ``steps * trajectories``, ``trajectories * n^2`` or the
        enumeration size above ``limits``.
    """
    raw = option_group(request, "simulate", _KEYS)
    if "percentiles" in raw and raw["percentiles"] != list(PERCENTILES):
        raise InvalidInput(f"{OPTIONS_FIELD}/percentiles", f"percentiles are fixed at {list(PERCENTILES)}")
    steps = _int_option(raw, "steps", limits.default_steps, limits.max_steps)
    # The defaults (200 steps, 10^4 trajectories) exceed the default work cap of 10^6
    # trajectory-steps, so an unspecified count shrinks to what the cap allows.
    fitting = max(
        int(_TRAJECTORIES.minimum or 0), min(limits.default_trajectories, limits.max_trajectory_steps // (steps or 1))
    )
    trajectories = _int_option(raw, "trajectories", fitting)
    seed = _int_option(raw, "seed", int(_SEED.default))
    exact_steps = _int_option(raw, "exact_steps", _EXACT_STEPS.default)
    assert steps is not None and trajectories is not None and seed is not None
    if steps * trajectories > limits.max_trajectory_steps:
        raise LimitExceeded(
            f"{OPTIONS_FIELD}/trajectories",
            f"steps * trajectories = {steps} * {trajectories} = {steps * trajectories} exceeds the limit "
            f"{limits.max_trajectory_steps}",
        )
    n = request.system.n
    if trajectories * n * n > limits.max_batch_floats:
        raise LimitExceeded(
            f"{OPTIONS_FIELD}/trajectories",
            f"{trajectories} trajectories of {n}x{n} covariances need {trajectories * n * n} floats; "
            f"the limit is {limits.max_batch_floats}",
        )
    if exact_steps is not None:
        check_exact_steps(exact_steps, len(packets_of(request)), limits, f"{OPTIONS_FIELD}/exact_steps")
    initial = raw.get("initial_channel", _INITIAL.default)
    if initial not in INITIAL_CHANNELS:
        raise InvalidInput(
            f"{OPTIONS_FIELD}/initial_channel", f"initial_channel must be one of {list(INITIAL_CHANNELS)}"
        )
    if "P0" in raw:
        P0, default = to_float(_parse_p0(raw["P0"], n)), False
    else:
        if request.system.Q is None:
            raise InvalidInput(
                "/system/Q", "Q (process noise covariance) is required to simulate the Riccati recursion"
            )
        P0, default = to_float(request.system.Q), True
    return SimulateOptions(steps, trajectories, seed, _readonly(P0), default, exact_steps, initial)


def matrix_or_none(m: np.ndarray | None) -> list[list[float]] | None:
    """A finite matrix as nested lists, or ``None`` if absent or not finite."""
    if m is None or not np.all(np.isfinite(m)):
        return None
    return [[float(x) for x in row] for row in m]
