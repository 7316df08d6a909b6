"""``kfio.System``: the plant, validated by the request validator.

The constructor writes its arguments as the ``system`` object of a request
file (:func:`kfio.model._coerce.python_tree`) and validates it with
:func:`kfio.model._request.parse_system`, the function the JSON route uses;
errors are renamed to the Python argument (``A[0][1]``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import fields
from typing import TYPE_CHECKING, Any

from .errors import InvalidInput
from .model import (
    DEFAULT_LIMITS,
    Limits,
    Matrix,
    Route,
    Sensor,
    SystemRecord,
    fraction_text,
    parse_system,
    python_tree,
    renamed,
)

if TYPE_CHECKING:
    from ._typing import MatrixLike, SensorsLike

_MATRICES = ("A", "C", "Q", "R")


#: Fraction texts longer than this are shown as ``~decimal`` in the repr (exact in :meth:`System.to_dict`).
REPR_TEXT_CHARS = 12


def _matrix_text(m: Matrix) -> list[list[str]]:
    return [[fraction_text(x) for x in row] for row in m]


def _readable(x: Any) -> str:
    """The exact text when short (``'11/10'``), else ``'~'`` and 6 significant digits (``'~1.00049'``)."""
    text = fraction_text(x)
    return text if len(text) <= REPR_TEXT_CHARS else f"~{float(x):.6g}"


class System(SystemRecord):
    """A linear plant observed through lossy packets: ``x[t+1] = A x[t] + w[t]``, ``y[t] = C x[t] + v[t]``.

    ``w ~ N(0, Q)`` and ``v ~ N(0, R)`` are white; the measurement ``y[t]``
    reaches the Kalman filter only when its packet arrives (Sinopoli et al.
    2004; Rohr, Marelli and Fu 2014, eq. (1)).  The constructor validates everything with the same
    rules as a request file: ``A`` square, ``C`` with ``n`` columns, ``Q``
    symmetric positive semidefinite, ``R`` symmetric positive definite, exactly.

    Parameters
    ----------
    A, C:
        Matrices: nested lists or tuples, numpy arrays of any real dtype, with
        entries that are ints, floats, numpy scalars, ``Fraction`` or exact
        strings (``"11/10"``, ``"1.1e-3"``).  A float means its shortest
        decimal text: ``1.1`` is ``11/10``, never the nearest double.
    Q, R:
        Process and measurement noise covariances (optional: the verdict of
        ``kfio.analyze`` does not depend on them; bounds and simulation need them).
    sensors:
        Packets, when rows of ``C`` travel separately: ``{"gps": [0], "imu": [1, 2]}``
        (or a sequence of ``{"name": ..., "rows": [...]}``); the rows must
        partition those of ``C``.
    limits:
        Size limits (default :data:`kfio.DEFAULT_LIMITS`); the requests that
        ``kfio.analyze`` and friends build from this system use them too.  A
        system may have up to ``limits.max_analyze_states`` states (120): that
        is what ``kfio.analyze`` accepts; the other commands refuse more than
        ``limits.max_states`` (40) when they build their request.

    Attributes
    ----------
    A, C, Q, R:
        Exact matrices, tuples of tuples of :class:`fractions.Fraction`.
    sensors:
        Tuple of :class:`kfio.Sensor`, or ``None``.

    Raises
    ------
    InvalidInput
        Naming the argument and the rule, e.g. ``A[0][1]: expected a number,
        got a complex`` or ``R: R must be positive definite``.

    Examples
    --------
    >>> import numpy as np
    >>> sys = System(A=np.array([[1.25, 0], [1, 1.1]]), C=[[1, 1]], Q=20 * np.eye(2), R=[[2.5]])
    >>> sys.A[1][1], sys.n, sys.p
    (Fraction(11, 10), 2, 1)
    >>> sys
    System(A=[['5/4', '0'], ['1', '11/10']], C=[['1', '1']], Q=[['20', '0'], ['0', '20']], R=[['5/2']])
    >>> System(A=[[1.0004897194771216]], C=[[1]])  # long exact texts: see to_dict()
    System(A=[['~1.00049']], C=[['1']])
    >>> System(A=[[1, 2j]], C=[[1]])
    Traceback (most recent call last):
    ...
    kfio.errors.InvalidInput: A[0][1]: expected a number, got a complex
    """

    def __init__(
        self,
        A: MatrixLike,
        C: MatrixLike,
        Q: MatrixLike | None = None,
        R: MatrixLike | None = None,
        sensors: SensorsLike | None = None,
        *,
        limits: Limits = DEFAULT_LIMITS,
    ) -> None:
        tree: dict[str, Any] = {"A": python_tree(A), "C": python_tree(C)}
        if Q is not None:
            tree["Q"] = python_tree(Q)
        if R is not None:
            tree["R"] = python_tree(R)
        routes: list[Route] = []
        if sensors is not None:
            tree["sensors"], routes = _sensors_tree(sensors)
        routes.append(("/system", "", tree, True))
        try:
            system = parse_system(tree, limits.for_command("analyze"))  # each command checks its own
        except InvalidInput as exc:
            raise renamed(exc, routes) from None
        for f in fields(SystemRecord):
            object.__setattr__(self, f.name, getattr(system, f.name))
        object.__setattr__(self, "_limits", limits)  # not a field: the requests built from it use them too

    @classmethod
    def from_statespace(
        cls, ss: Any, Q: MatrixLike | None = None, R: MatrixLike | None = None, *, sensors: SensorsLike | None = None
    ) -> System:
        """The plant of a discrete-time python-control ``StateSpace``.

        Takes ``A`` and ``C`` of ``x[t+1] = A x[t] + B u[t] + w[t]``,
        ``y[t] = C x[t] + D u[t] + v[t]``.  ``B`` and ``D`` are left out: a
        known input shifts the estimate but not the error covariance, so
        stability of the filter (Sinopoli et al. 2004) does not depend on them.
        Needs the optional extra ``kfio[control]``; kfio itself never imports
        python-control.

        Parameters
        ----------
        ss:
            ``control.StateSpace`` with a discrete time base (``dt > 0`` or
            ``dt=True``).  A continuous-time system is refused: discretize it
            first (``control.c2d(ss, Ts)`` or ``ss.sample(Ts)``).
        Q, R, sensors:
            As in :class:`System`.

        Raises
        ------
        InvalidInput
            Field ``ss``: not a state-space system, continuous time, or an
            unspecified time base.

        Examples
        --------
        >>> import control
        >>> System.from_statespace(control.ss([[1.1]], [[1]], [[1]], [[0]], 0.1), Q=[[1]], R=[[1]])
        System(A=[['11/10']], C=[['1']], Q=[['1']], R=[['1']])
        """
        if not all(hasattr(ss, a) for a in ("A", "C", "dt")):
            kind = type(ss).__name__
            raise InvalidInput(
                "ss",
                f"expected a python-control StateSpace; got a {kind} (convert a transfer function with control.ss)",
            )
        dt = ss.dt
        if dt is None:
            raise InvalidInput(
                "ss",
                "the StateSpace has an unspecified time base (dt=None); kfio needs a discrete-time system, "
                "e.g. control.ss(A, B, C, D, dt) with the sampling period dt",
            )
        if dt is False or (dt is not True and dt == 0):
            raise InvalidInput(
                "ss",
                "the StateSpace is continuous-time (dt=0); kfio analyzes discrete-time systems "
                "x[t+1] = A x[t] + w[t]: discretize it first, e.g. control.c2d(ss, Ts) or ss.sample(Ts)",
            )
        return cls(A=ss.A, C=ss.C, Q=Q, R=R, sensors=sensors)

    def to_dict(self) -> dict[str, Any]:
        """The ``system`` object of a request file (exact values as fraction text)."""
        out: dict[str, Any] = {}
        for name in _MATRICES:
            m = getattr(self, name)
            if m is not None:
                out[name] = _matrix_text(m)
        if self.sensors is not None:
            out["sensors"] = [{"name": s.name, "rows": list(s.rows)} for s in self.sensors]
        return out

    def __repr__(self) -> str:
        """Short exact texts as they are, long ones (a ``control.c2d`` plant) as ``'~'`` and a decimal."""
        parts = [
            f"{k}={[[_readable(x) for x in row] for row in getattr(self, k)]!r}"
            for k in _MATRICES
            if getattr(self, k) is not None
        ]
        if self.sensors is not None:
            parts.append(f"sensors={ {s.name: list(s.rows) for s in self.sensors}!r}")
        return f"System({', '.join(parts)})"


def is_statespace(obj: Any) -> bool:
    """Whether ``obj`` looks like a python-control ``StateSpace`` (kfio never imports python-control)."""
    return not isinstance(obj, SystemRecord) and all(hasattr(obj, a) for a in ("A", "B", "C", "dt"))


def plant_of(system: Any, Q: Any = None, R: Any = None, *, limits: Limits | None = None) -> System:
    """The :class:`System` of a ``system`` argument, with the ``Q`` and ``R`` keywords of the public functions.

    The one rule of every function that takes a system: ``system`` is a
    :class:`System` or a discrete-time python-control ``StateSpace``; ``Q``
    and ``R`` fill what the plant lacks (a ``StateSpace`` never has them), and
    a keyword for a matrix the :class:`System` already has is refused, naming
    it, so that no value is silently replaced.
    """
    given = {"Q": Q, "R": R}
    if isinstance(system, SystemRecord):
        for name, value in given.items():
            if value is not None and getattr(system, name) is not None:
                raise InvalidInput(
                    name, f"the System already has {name}: give it to kfio.System or as this keyword, not both"
                )
        lim = limits if limits is not None else getattr(system, "_limits", DEFAULT_LIMITS)
        if isinstance(system, System) and Q is None and R is None and limits is None:
            return system
        return System(
            system.A,
            system.C,
            system.Q if Q is None else Q,
            system.R if R is None else R,
            None if system.sensors is None else list(system.sensors),
            limits=lim,
        )
    if is_statespace(system):
        try:
            return System.from_statespace(system, Q=Q, R=R)
        except InvalidInput as exc:
            raise (InvalidInput("system", exc.rule) if exc.field == "ss" else exc) from None
    raise InvalidInput(
        "system", f"expected a kfio.System or a discrete-time python-control StateSpace; got a {type(system).__name__}"
    )


def _sensors_tree(sensors: Any) -> tuple[list[Any], list[Route]]:
    """Sensors as the request's list of ``{name, rows}``, and routes naming them as the user wrote them."""
    if isinstance(sensors, Mapping):
        tree = [{"name": name, "rows": python_tree(rows)} for name, rows in sensors.items()]
        routes: list[Route] = []
        for i, name in enumerate(sensors):
            label = f"sensors[{name!r}]"
            routes.append((f"/system/sensors/{i}/rows", label, tree[i]["rows"], False))
            routes.append((f"/system/sensors/{i}", label, tree[i], False))
        return tree, routes
    if isinstance(sensors, Sequence) and not isinstance(sensors, (str, bytes)):
        items = [{"name": s.name, "rows": list(s.rows)} if isinstance(s, Sensor) else s for s in sensors]
        return python_tree(items), []
    return sensors, []  # the validator says what it expected


__all__ = ["System", "is_statespace", "plant_of"]
