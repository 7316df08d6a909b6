"""The loop request: plant with input matrix, sensor and actuator channels, controller, options.

A loop request is a kfio request (``system``, ``channel``) with four more
fields (Schenato, Sinopoli, Franceschetti, Poolla and Sastry 2007, Sec. II)::

    {"system": {"A": ..., "B": ..., "C": ..., "Q": ..., "R": ..., "sensors": ...},
     "channel": <the sensor packets' channel, any kfio channel>,
     "actuator_channel": <bernoulli | gilbert_elliott | markov>,
     "controller": {"gains": {"feedback": F, "estimator": E}, "form": "predictor" | "filter"},
     "cost": {"W": ..., "U": ...},
     "options": {"loop": {"protocol": "tcp" | "udp", "on_loss": "zero" | "hold", "region": 11}}}

The plant is ``x[t+1] = A x[t] + B a[t] + w[t]`` where ``a[t]`` is the input
the actuator applies: ``u[t]`` when the actuator packet arrives, else ``0``
(``on_loss: zero``, the paper's model) or ``a[t-1]`` (``on_loss: hold``).
The gains are named by their role, never by a letter: the control law is
``u[t] = -F x_hat[t]`` with ``F = feedback`` (python-control's ``dlqr`` returns
it as ``K``), and ``E = estimator`` is the estimator gain, in the form
python-control's ``dlqe`` returns it as ``L`` (``predictor``: ``x_hat[t+1|t] =
A x_hat[t|t-1] + B a_hat[t] + E (y[t] - C x_hat[t|t-1])``) or in ``filter``
form (``x_hat[t|t] = x_hat[t|t-1] + E (y[t] - C x_hat[t|t-1])``, then
``u[t] = -F x_hat[t|t]``).  Schenato, Sinopoli, Franceschetti, Poolla and
Sastry (2007) call them ``L`` and ``K``, python-control the other way round,
so the letters are refused with a message saying which is which.
Lost sensor rows contribute nothing to the innovation.  ``cost`` weighs
``x' W x + a' U a`` (default ``W = I``, ``U = 0``).

Every number is read exactly from its decimal text (:func:`kfio.parse_number`);
the system and channels go through the one validator of every other command.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from ..errors import InvalidInput
from ..model import (
    DEFAULT_LIMITS,
    Channel,
    Limits,
    MarkovChannel,
    Matrix,
    check_keys,
    check_symmetric,
    is_psd,
    load_json,
    option_field,
    option_fields,
    parse_channel,
    parse_markov_channel,
    parse_matrix,
    parse_system,
    parse_time_budget,
    value_text,
)
from ..model import SystemRecord as System

_TOP_KEYS = {"system", "channel", "actuator_channel", "controller", "cost", "options"}
_LOOP_OPTIONS = {f.name for f in option_fields("loop")}
PROTOCOLS = option_field("loop", "protocol").enum
ON_LOSS = option_field("loop", "on_loss").enum
FORMS = ("predictor", "filter")
_REGION = option_field("loop", "region")
#: Smallest and largest grid of ``options.loop.region``.
MIN_REGION_POINTS, MAX_REGION_POINTS = int(_REGION.minimum or 0), int(_REGION.maximum or 0)


@dataclass(frozen=True)
class LoopRequest:
    """A validated loop request (see the module docstring for the model).

    ``controller`` is ``"gains"`` when the request gives ``feedback`` and
    ``estimator``, and ``"lqg"`` when kfio computed them from the weights
    (:mod:`kfio.loop._lqg`).  ``feedback`` is ``F`` of ``u = -F x_hat``
    (python-control's ``dlqr`` ``K``), ``estimator`` the estimator gain
    (python-control's ``dlqe`` ``L``).
    """

    system: System
    B: Matrix
    channel: Channel
    actuator: MarkovChannel
    estimator: Matrix
    feedback: Matrix
    form: str
    W: Matrix
    U: Matrix
    protocol: str = "tcp"
    on_loss: str = "zero"
    controller: str = "gains"
    time_budget_s: float | None = None
    region: int | None = None

    @property
    def K(self) -> Matrix:
        """The estimator gain under its letter in Schenato, Sinopoli, Franceschetti, Poolla and Sastry (2007): :attr:`estimator`."""
        return self.estimator

    @property
    def L(self) -> Matrix:
        """The feedback gain under its letter in Schenato, Sinopoli, Franceschetti, Poolla and Sastry (2007): :attr:`feedback`."""
        return self.feedback

    @property
    def n(self) -> int:
        return len(self.system.A)

    @property
    def m(self) -> int:
        return len(self.B[0])

    @property
    def p(self) -> int:
        return len(self.system.C)


#: The gains of a ``controller.gains`` object, by role, and their shapes (``n`` states, ``m`` inputs, ``p`` outputs).
GAIN_SHAPES = {"feedback": "m x n", "estimator": "n x p"}

#: Why the letters are refused: the paper and python-control use them the other way round.
LETTERS_REFUSED = (
    "kfio names gains by role: 'feedback' (u = -F x_hat; python-control's dlqr K) and 'estimator' "
    "(python-control's dlqe L); Schenato, Sinopoli, Franceschetti, Poolla and Sastry (2007) write them L and K, "
    "the other way round, so the letters are ambiguous"
)


def _no_letters(gains: Any) -> Any:
    """``gains`` unchanged, or :class:`InvalidInput` at ``/controller/gains/K`` (or ``L``) saying which gain is which."""
    if isinstance(gains, dict):
        for letter in ("K", "L"):
            if letter in gains:
                raise InvalidInput(
                    f"/controller/gains/{letter}", f"{LETTERS_REFUSED}; give {letter!r} as 'feedback' or 'estimator'"
                )
    return gains


def _identity(n: int) -> Matrix:
    from fractions import Fraction

    return tuple(tuple(Fraction(int(i == j)) for j in range(n)) for i in range(n))


def _zeros(r: int, c: int) -> Matrix:
    from fractions import Fraction

    return tuple(tuple(Fraction(0) for _ in range(c)) for _ in range(r))


def _shaped(obj: Any, where: str, name: str, rows: int, cols: int, limits: Limits) -> Matrix:
    m = parse_matrix(obj, where, name, limits, max(rows, limits.max_states), max(cols, limits.max_states))
    if len(m) != rows or len(m[0]) != cols:
        raise InvalidInput(where, f"{name} must be {rows}x{cols}; got {len(m)}x{len(m[0])}")
    return m


def _weights(obj: Any, where: str, n: int, m: int, limits: Limits) -> tuple[Matrix, Matrix]:
    obj = check_keys(obj, where, {"W", "U"}, set())
    W = _identity(n)
    U = _zeros(m, m)
    if "W" in obj:
        W = _shaped(obj["W"], f"{where}/W", "W", n, n, limits)
        check_symmetric(W, f"{where}/W", "W", n)
        if not is_psd(W, strict=False, where=f"{where}/W"):
            raise InvalidInput(f"{where}/W", "W must be positive semidefinite")
    if "U" in obj:
        U = _shaped(obj["U"], f"{where}/U", "U", m, m, limits)
        check_symmetric(U, f"{where}/U", "U", m)
        if not is_psd(U, strict=False, where=f"{where}/U"):
            raise InvalidInput(f"{where}/U", "U must be positive semidefinite")
    return W, U


def parse_loop_request(obj: Any, limits: Limits = DEFAULT_LIMITS) -> LoopRequest:
    """Validate a loop request (the JSON tree of :func:`kfio.load_json`); errors name the field and rule."""
    obj = check_keys(obj, "", _TOP_KEYS, {"system", "channel", "actuator_channel", "controller"})
    sys_obj = obj["system"]
    if not isinstance(sys_obj, dict):
        raise InvalidInput("/system", "expected a JSON object")
    if "B" not in sys_obj:
        raise InvalidInput("/system/B", "required field is missing: a loop needs the input matrix B")
    for key in ("Q", "R"):
        if key not in sys_obj:
            raise InvalidInput(f"/system/{key}", f"required field is missing: a loop's cost needs the noise {key}")
    system = parse_system({k: v for k, v in sys_obj.items() if k != "B"}, limits)
    n, p = system.n, system.p
    B = parse_matrix(sys_obj["B"], "/system/B", "B", limits, limits.max_states, limits.max_states)
    if len(B) != n:
        raise InvalidInput("/system/B", f"B must have {n} rows (A is {n}x{n}); got {len(B)}")
    m = len(B[0])
    channel = parse_channel(obj["channel"], system, limits)
    actuator = parse_markov_channel(obj["actuator_channel"], limits, "/actuator_channel")

    ctrl = obj["controller"]
    if not isinstance(ctrl, dict):
        raise InvalidInput("/controller", "expected a JSON object")
    if "lqg" in ctrl:
        check_keys(ctrl, "/controller", {"lqg", "form"}, set())
        W, U = _weights(ctrl["lqg"], "/controller/lqg", n, m, limits)
        if "U" not in ctrl["lqg"] or not is_psd(U, strict=True, where="/controller/lqg/U"):
            raise InvalidInput("/controller/lqg/U", "U is required and must be positive definite for LQG gains")
        source = "lqg"
        estimator = feedback = None
        # filter form by default: the optimal TCP-like controller applies u = -L x_hat[t|t]
        form = ctrl.get("form", "filter")
        if form not in FORMS:
            raise InvalidInput("/controller/form", f"form must be one of {', '.join(FORMS)}; got {form!r}")
    else:
        check_keys(ctrl, "/controller", {"gains", "form"}, {"gains"})
        gains = check_keys(_no_letters(ctrl["gains"]), "/controller/gains", set(GAIN_SHAPES), set(GAIN_SHAPES))
        feedback = _shaped(gains["feedback"], "/controller/gains/feedback", "feedback", m, n, limits)
        estimator = _shaped(gains["estimator"], "/controller/gains/estimator", "estimator", n, p, limits)
        form = ctrl.get("form", "predictor")
        if form not in FORMS:
            raise InvalidInput("/controller/form", f"form must be one of {', '.join(FORMS)}; got {value_text(form)}")
        source = "gains"
        W, U = _identity(n), _zeros(m, m)
    if "cost" in obj:
        W, U = _weights(obj["cost"], "/cost", n, m, limits)

    protocol, on_loss = option_field("loop", "protocol").default, option_field("loop", "on_loss").default
    budget, region = None, None
    if "options" in obj:
        opts = check_keys(obj["options"], "/options", {"loop", "time_budget_s"}, set())
        if "time_budget_s" in opts:
            budget = parse_time_budget(opts["time_budget_s"], limits)
        if "loop" in opts:
            lo: Mapping[str, Any] = check_keys(opts["loop"], "/options/loop", _LOOP_OPTIONS, set())
            protocol = lo.get("protocol", protocol)
            if protocol not in PROTOCOLS:
                raise InvalidInput(
                    "/options/loop/protocol", f"protocol must be 'tcp' or 'udp'; got {value_text(protocol)}"
                )
            on_loss = lo.get("on_loss", on_loss)
            if on_loss not in ON_LOSS:
                raise InvalidInput(
                    "/options/loop/on_loss", f"on_loss must be 'zero' or 'hold'; got {value_text(on_loss)}"
                )
            if "region" in lo:
                region = lo["region"]
                if isinstance(region, bool) or not isinstance(region, int) or not _REGION.admits(region):
                    raise InvalidInput(
                        _REGION.pointer,
                        f"region must be an integer number of points in [{MIN_REGION_POINTS}, {MAX_REGION_POINTS}]",
                    )
    req = LoopRequest(
        system,
        B,
        channel,
        actuator,
        estimator or (),
        feedback or (),
        form,
        W,
        U,
        protocol,
        on_loss,
        source,
        budget,
        region,
    )
    if source == "lqg":
        from ._lqg import with_lqg_gains

        req = with_lqg_gains(req)
    return req


def load_loop_request(text: str | bytes, limits: Limits = DEFAULT_LIMITS) -> LoopRequest:
    """Parse and validate loop request JSON text in one step."""
    return parse_loop_request(load_json(text), limits)


__all__ = [
    "FORMS",
    "GAIN_SHAPES",
    "LETTERS_REFUSED",
    "ON_LOSS",
    "PROTOCOLS",
    "LoopRequest",
    "load_loop_request",
    "parse_loop_request",
]
