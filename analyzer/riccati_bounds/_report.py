"""Frozen result objects of ``kfio bounds``.

Their JSON is built by the views of :mod:`kfio._json._bounds` (``to_dict()``):
every key is always present, floats are finite (a value that does not exist is
``null`` next to a ``reason``), matrices are nested lists, exact rationals are
strings such as ``"9/25"``.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING, Any

import numpy as np

from .._json import json_float as num
from .._reporting import Report, ReportPart
from .._verdicts import Verdict
from ..model import Packet
from ._certificate import StabilityCertificate
from ._filtered import FilteredBounds
from ._phat import PHat
from ._riccati import VBarIteration
from ._search import UpperBound
from ._vbar_sdp import SDPSolution

if TYPE_CHECKING:  # the exact grid is computed by kfio.stability, which imports no bounds
    from ..stability import RegionGrid


def _trace(M: np.ndarray | None) -> float | None:
    return None if M is None else num(float(np.trace(M)))


@dataclass(frozen=True)
class CriticalInterval(ReportPart):
    """``lower <= lambda_c <= upper`` for one packet, the other packets held at their probabilities.

    ``lower = max(0, 1 - 1/(rho(A)^2 prod_{r != s}(1 - lambda_r)))`` (Sinopoli et al. (2004)
    Theorem 3; Liu and Goldsmith (2004) Theorem 3); ``upper`` is the bisection of
    :meth:`kfio.riccati_bounds._search.CertifiedSearch.bisect`.
    """

    packet: Packet
    arrival_probability: Fraction
    lower: float
    upper: UpperBound
    tolerance: float


@dataclass(frozen=True)
class CovarianceBounds(ReportPart):
    """``S_bar <= lim E[P_t] <= V_bar`` at the operating point (Sinopoli et al. (2004) Theorem 4; Liu and Goldsmith (2004) Theorem 4)."""

    s_bar: np.ndarray | None
    s_bar_residual: float | None
    v_bar: VBarIteration
    sdp: SDPSolution | None
    sdp_reason: str | None
    filtered: FilteredBounds | None = None

    @property
    def sdp_difference(self) -> float | None:
        V, sdp = self.v_bar.matrix, self.sdp
        if V is None or sdp is None or sdp.matrix is None:
            return None
        return float(np.linalg.norm(sdp.matrix - V) / np.linalg.norm(V))

    @property
    def ordering_margin(self) -> float | None:
        """``lambda_min(V_bar - S_bar) / ||V_bar||``: ``>= 0`` up to rounding when ``S_bar <= V_bar``."""
        if self.s_bar is None or self.v_bar.matrix is None:
            return None
        V = self.v_bar.matrix
        return float(np.linalg.eigvalsh(V - self.s_bar)[0] / np.linalg.norm(V, 2))


@dataclass(frozen=True)
class PHatBounds(ReportPart):
    """Rohr, Marelli and Fu (2010)'s ``P_hat_N`` for ``N = 1, 2, 4, ...`` up to the horizon (and the horizon itself)."""

    horizon: int
    entries: tuple[PHat, ...]
    #: ``(1 - lambda) P_hat_N + lambda F(P_hat_N)`` per entry: the filtered counterpart (kfio.riccati_bounds._filtered)
    filtered: tuple[np.ndarray | None, ...] = ()

    def subsequences_monotone(self) -> bool | None:
        """``P_hat_{cN} <= P_hat_N`` (Rohr, Marelli and Fu (2010) Theorem 1, eq. 18) for every pair present, up to rounding."""
        ok = None
        have = {e.N: e.matrix for e in self.entries if e.matrix is not None}
        for N, M in have.items():
            for cN, Mc in have.items():
                if cN > N and cN % N == 0:
                    tol = 1e-9 * np.linalg.norm(M, 2)
                    ok = (ok is not False) and bool(np.linalg.eigvalsh(M - Mc)[0] >= -tol)
        return ok


@dataclass(frozen=True)
class RegionMap(ReportPart):
    """Liu and Goldsmith (2004), Figs. 4-5: the ``(lambda_1, lambda_2)`` square labelled by the bounds."""

    axes: tuple[str, str]
    values: tuple[Fraction, ...]
    labels: tuple[tuple[str, ...], ...]
    certified_cells: int
    lmi_solves: int
    exact: RegionGrid | None = None  # kfio.design._regions.exact_region_grid(...), an extension


#: The bounds decide only where they are conclusive; the exact verdict is another command's.
NO_EXACT_VERDICT = (
    "exact verdict: not computed here (kfio analyze gives it, Rohr, Marelli and Fu 2014, Theorem 1); "
    "the bounds below are evidence"
)


@dataclass(frozen=True, repr=False)
class BoundsReport(Report):
    """Everything ``kfio bounds`` reports; :meth:`to_dict` is the JSON, :meth:`summary` the text."""

    packets: tuple[Packet, ...]
    arrival: tuple[Fraction, ...]
    rho: float
    hypotheses: dict[str, Any]
    verdict: Verdict
    verdict_reason: str
    verdict_certificate: StabilityCertificate | None
    critical: tuple[CriticalInterval, ...]
    variance_threshold: float | None
    covariance: CovarianceBounds
    p_hat: PHatBounds | None
    region: RegionMap | None
    trace_target: Any = None  # kfio.riccati_bounds._targets.TraceTarget when options.bounds.trace_target is set

    def __post_init__(self) -> None:
        object.__setattr__(self, "verdict", Verdict(self.verdict))

    @property
    def one_packet(self) -> bool:
        return len(self.packets) == 1

    def _repr_items(self) -> list[tuple[str, Any]]:
        intervals = tuple((c.lower, None if c.upper.value is None else float(c.upper.value)) for c in self.critical)
        return [
            ("exact_verdict", "not computed (kfio.analyze)"),
            ("verdict_by_bounds", self.verdict),
            ("critical_intervals", intervals),
            ("trace_S_bar", _trace(self.covariance.s_bar)),
            ("trace_V_bar", _trace(self.covariance.v_bar.matrix)),
        ]

    def notes(self) -> list[str]:
        """Caveats of the report: per-sensor reading of the intervals, failed hypotheses of Sinopoli et al. (2004)."""
        notes = []
        if not self.one_packet:
            notes.append(
                "several sensors: critical_probability is per sensor, see sensors[*].critical_interval; "
                "P_hat_N and the variance threshold are one-packet results (Rohr, Marelli and Fu 2010)"
            )
        bad = [k for k in ("A_Q_controllable", "A_C_detectable") if self.hypotheses.get(k) is False]
        if bad:
            notes.append(
                f"hypotheses of Sinopoli et al. 2004, Theorems 2-5 fail ({', '.join(bad)}): the bounds are computed "
                "but those theorems do not cover them"
            )
        return notes

    def summary(self) -> str:
        lines = []
        where = ", ".join(
            f"{p.name or 'packet'}: lambda = {float(lam):g}" for p, lam in zip(self.packets, self.arrival)
        )
        lines.append(NO_EXACT_VERDICT)
        lines.append(f"kfio bounds ({len(self.packets)} packet{'s' if len(self.packets) > 1 else ''}; {where})")
        lines.append(f"  rho(A) = {self.rho:.6g}")
        for p, c in zip(self.packets, self.critical):
            who = "lambda_c" if self.one_packet else f"critical probability of {p.name}"
            up = c.upper
            upper = (
                f"{float(up.value):.9g} (certificate re-checked: {up.certificate.method}, gains from {up.certificate.route})"
                if up.value is not None and up.certificate is not None
                else f"none ({up.reason})"
            )
            lines.append(f"  {c.lower:.9g} (closed form) <= {who} <= {upper}")
        lines.append(f"  at the operating point: {self.verdict} ({self.verdict_reason})")
        if self.variance_threshold is not None:
            lines.append(f"  finite variance needs lambda > {self.variance_threshold:.6g} (Rohr, Marelli and Fu 2010)")
        cov = self.covariance
        s = cov.s_bar
        s_text = f"trace {np.trace(s):.6g}" if s is not None else "none"
        lines.append(f"  S_bar (lower bound of lim E[P(t|t-1)]): {s_text}")
        V = cov.v_bar.matrix
        if V is not None:
            d = cov.sdp_difference
            agree = f"SDP agrees to {d:.1e}" if d is not None else f"SDP: {cov.sdp_reason or 'no answer'}"
            lines.append(f"  V_bar (upper bound of lim E[P(t|t-1)]): trace {np.trace(V):.6g} ({agree})")
        else:
            lines.append(f"  V_bar: none ({cov.v_bar.reason})")
        if cov.filtered is not None and (cov.filtered.lower is not None or cov.filtered.upper is not None):
            f_lo, f_up = cov.filtered.lower, cov.filtered.upper
            lo_t = "none" if f_lo is None else f"{np.trace(f_lo):.6g}"
            up_t = "none" if f_up is None else f"{np.trace(f_up):.6g}"
            lines.append(f"  filtered P(t|t): trace of lim E in [{lo_t}, {up_t}] (from S_bar and V_bar)")
        if self.p_hat is not None:
            parts = []
            t1 = None
            for e in self.p_hat.entries:
                if e.matrix is None:
                    parts.append(f"N={e.N}: none")
                    continue
                t = float(np.trace(e.matrix))
                t1 = t if e.N == 1 else t1
                parts.append(f"N={e.N}: {t:.6g}" + (f" ({100 * (1 - t / t1):+.1f}%)" if t1 and e.N > 1 else ""))
            lines.append("  P_hat_N traces (Rohr, Marelli and Fu 2010): " + ", ".join(parts))
        if self.region is not None:
            r = self.region
            lines.append(
                f"  region map {len(r.values)}x{len(r.values)} ({r.axes[0]} down, {r.axes[1]} across; "
                "S stable, U unstable, . undecided):"
            )
            sym = {"stable": "S", "unstable": "U", "undecided": "."}
            for v, row in zip(r.values, r.labels):
                lines.append(f"    {float(v):5.3f} " + "".join(sym[x] for x in row))
        if self.trace_target is not None:
            lines.append("  " + self.trace_target.summary_line())
        lines.extend(f"  note: {n}" for n in self.notes())
        return "\n".join(lines)
