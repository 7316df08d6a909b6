"""Frozen result objects of ``kfio bounds`` and the one place their JSON is built.

The JSON is stable: every key is always present, floats are finite (a value
that does not exist is ``null`` next to a ``reason``), matrices are nested
lists, exact rationals are strings such as ``"9/25"``.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING, Any

import numpy as np

from .._json import json_float as num  # the one JSON-safe float of kfio
from .._reporting import Report, stamp
from ..model._exact import fraction_text
from ..model._types import Packet
from ._certificate import StabilityCertificate
from ._filtered import FilteredBounds
from ._lmi import SDPSolution
from ._phat import PHat
from ._riccati import VBarIteration
from ._search import UpperBound

if TYPE_CHECKING:  # the exact grid is computed by kfio.stability, which imports no bounds
    from ..stability._regions import RegionGrid

#: Relative agreement required between the V_bar iteration and the SDP.
SDP_AGREEMENT = 1e-6


def mat(M: np.ndarray | None) -> list[list[float | None]] | None:
    return None if M is None else [[num(x) for x in row] for row in np.atleast_2d(M)]


def _trace(M: np.ndarray | None) -> float | None:
    return None if M is None else num(float(np.trace(M)))


@dataclass(frozen=True)
class CriticalInterval:
    """``lower <= lambda_c <= upper`` for one packet, the other packets held at their probabilities.

    ``lower = max(0, 1 - 1/(rho(A)^2 prod_{r != s}(1 - lambda_r)))`` (Sinopoli et al. (2004)
    Theorem 3; Liu and Goldsmith (2004) Theorem 3); ``upper`` is the bisection of
    :meth:`kfio.mare._search.CertifiedSearch.bisect`.
    """

    packet: Packet
    arrival_probability: Fraction
    lower: float
    upper: UpperBound
    tolerance: float

    def to_dict(self) -> dict[str, Any]:
        up = self.upper
        value = None if up.value is None else float(up.value)
        return {
            "lower": {
                "value": num(self.lower),
                "formula": "max(0, 1 - 1/(rho(A)^2 prod_{other sensors r} (1 - lambda_r)))",
                "certificate": {
                    "method": "closed_form",
                    "checked": "rho(A) from numpy.linalg.eigvals; below this value the Lyapunov lower bound "
                    "S_bar diverges (Sinopoli et al. 2004, Theorem 3; Liu and Goldsmith 2004, Theorem 3)",
                },
            },
            "upper": {
                "value": value,
                "exact": None if up.value is None else fraction_text(up.value),
                "reason": up.reason,
                "not_certified_at": None if up.lower_end is None else float(up.lower_end),
                "tolerance": self.tolerance,
                "lmi_solves": up.steps,
                "certificate": None if up.certificate is None else up.certificate.describe(),
            },
            "gap": None if value is None else num(value - self.lower),
        }


@dataclass(frozen=True)
class CovarianceBounds:
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

    def to_dict(self) -> dict[str, Any]:
        it, d = self.v_bar, self.sdp_difference
        order = self.ordering_margin
        return {
            "S_bar": {
                "exists": self.s_bar is not None,
                "matrix": mat(self.s_bar),
                "trace": _trace(self.s_bar),
                "reason": None
                if self.s_bar is not None
                else "(1 - lambda) rho(A)^2 >= 1 (for several sensors: "
                "prod_s (1 - lambda_s) rho(A)^2 >= 1): the Lyapunov equation has no solution and E[P_t] diverges",
                "method": "scipy.linalg.solve_discrete_lyapunov",
                "residual": num(self.s_bar_residual),
            },
            "V_bar": {
                "exists": it.matrix is not None,
                "matrix": mat(it.matrix),
                "trace": _trace(it.matrix),
                "reason": it.reason,
                "iteration": {
                    "method": "monotone iteration from 0 (Sinopoli et al. 2004, Theorem 6(a)), finished by monotone policy "
                    "iteration from above; the two bracket V_bar",
                    "iterations": it.iterations,
                    "policy_iteration_steps": it.newton_steps,
                    "residual": num(it.residual),
                    "bracket_gap": num(it.bracket_gap),
                },
                "sdp": {
                    "status": None if self.sdp is None else self.sdp.status,
                    "matrix": None if self.sdp is None else mat(self.sdp.matrix),
                    "trace": None if self.sdp is None else _trace(self.sdp.matrix),
                    "reason": self.sdp_reason,
                    "relative_difference": num(d),
                    "agrees": None if d is None else bool(d <= SDP_AGREEMENT),
                },
            },
            "ordering": {
                "S_bar_le_V_bar": None if order is None else bool(order >= -1e-9),
                "min_eigenvalue_of_difference_relative": num(order),
            },
            "covariance": "predictor P(t|t-1): S_bar <= lim E[P(t|t-1)] <= V_bar",
            "filtered": None if self.filtered is None else self.filtered.to_dict(),
        }


@dataclass(frozen=True)
class PHatBounds:
    """Rohr, Marelli and Fu (2010)'s ``P_hat_N`` for ``N = 1, 2, 4, ...`` up to the horizon (and the horizon itself)."""

    horizon: int
    entries: tuple[PHat, ...]
    #: ``(1 - lambda) P_hat_N + lambda F(P_hat_N)`` per entry: the filtered counterpart (kfio.mare._filtered)
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

    def to_dict(self) -> dict[str, Any]:
        t1 = next((_trace(e.matrix) for e in self.entries if e.N == 1), None)
        out = []
        filtered = self.filtered or (None,) * len(self.entries)
        for e, f in zip(self.entries, filtered):
            t = _trace(e.matrix)
            out.append(
                {
                    "N": e.N,
                    "exists": e.matrix is not None,
                    "trace": t,
                    "improvement_over_P_hat_1_percent": None if t is None or t1 is None else num(100 * (1 - t / t1)),
                    "matrix": mat(e.matrix),
                    "iterations": e.iterations,
                    "started_from_N": e.start,
                    "last_step": num(e.last_step),
                    "reason": e.reason,
                    "filtered_trace": _trace(f),
                }
            )
        return {
            "horizon": self.horizon,
            "method": "fixed point of g_N (Rohr, Marelli and Fu 2010, eqs. 11, 15, 22), g_N evaluated level by level on batches",
            "entries": out,
            "covariance": "predictor P(t|t-1); filtered_trace is the trace of sum_S pi(S) F_S(P_hat_N), an upper "
            "bound of lim sup E[P(t|t)] by the concavity argument of the filtered V_bar",
            "monotone_subsequences_hold": self.subsequences_monotone(),
        }


@dataclass(frozen=True)
class RegionMap:
    """Liu and Goldsmith (2004), Figs. 4-5: the ``(lambda_1, lambda_2)`` square labelled by the bounds."""

    axes: tuple[str, str]
    values: tuple[Fraction, ...]
    labels: tuple[tuple[str, ...], ...]
    certified_cells: int
    lmi_solves: int
    exact: RegionGrid | None = None  # kfio.stability._regions.exact_region_grid(...), an extension

    def to_dict(self) -> dict[str, Any]:
        return {
            "axes": list(self.axes),
            "values": [float(v) for v in self.values],
            "labels": [list(row) for row in self.labels],
            "indexing": "labels[i][j] is the cell lambda_1 = values[i], lambda_2 = values[j]",
            "legend": {
                "stable": "the LMI (Liu and Goldsmith 2004, eq. 20) is feasible, by a re-checked certificate at this cell or at a "
                "cell below it in both coordinates (feasibility is monotone, Liu and Goldsmith 2004, Lemma 3)",
                "unstable": "prod_s (1 - lambda_s) rho(A)^2 >= 1: the lower bound diverges",
                "undecided": "neither bound decides",
            },
            "certified_cells": self.certified_cells,
            "lmi_solves": self.lmi_solves,
            "exact": None if self.exact is None else self.exact.to_dict(),
        }


@dataclass(frozen=True, repr=False)
class BoundsReport(Report):
    """Everything ``kfio bounds`` reports; :meth:`to_dict` is the JSON, :meth:`summary` the text."""

    packets: tuple[Packet, ...]
    arrival: tuple[Fraction, ...]
    rho: float
    hypotheses: dict[str, Any]
    verdict: str
    verdict_reason: str
    verdict_certificate: StabilityCertificate | None
    critical: tuple[CriticalInterval, ...]
    variance_threshold: float | None
    covariance: CovarianceBounds
    p_hat: PHatBounds | None
    region: RegionMap | None
    trace_target: Any = None  # kfio.mare._targets.TraceTarget when options.bounds.trace_target is set

    @property
    def one_packet(self) -> bool:
        return len(self.packets) == 1

    def _repr_items(self) -> list[tuple[str, Any]]:
        intervals = tuple((c.lower, None if c.upper.value is None else float(c.upper.value)) for c in self.critical)
        return [
            ("verdict", self.verdict),
            ("critical_intervals", intervals),
            ("trace_S_bar", _trace(self.covariance.s_bar)),
            ("trace_V_bar", _trace(self.covariance.v_bar.matrix)),
        ]

    def to_dict(self) -> dict[str, Any]:
        one = self.one_packet
        packets = [
            {
                "name": p.name,
                "rows": list(p.rows),
                "arrival_probability": float(lam),
                "arrival_probability_exact": fraction_text(lam),
            }
            for p, lam in zip(self.packets, self.arrival)
        ]
        sensors = None
        if not one:
            sensors = [{"name": p.name, "critical_interval": c.to_dict()} for p, c in zip(self.packets, self.critical)]
        return {
            **stamp(),
            "command": "bounds",
            "packets": packets,
            "spectral_radius_A": num(self.rho),
            "hypotheses": self.hypotheses,
            "operating_point": {
                "verdict_by_bounds": self.verdict,
                "reason": self.verdict_reason,
                "certificate": None if self.verdict_certificate is None else self.verdict_certificate.describe(),
            },
            "critical_probability": self.critical[0].to_dict() if one else None,
            "sensors": sensors,
            "variance_threshold": {
                "value": num(self.variance_threshold),
                "formula": "max(0, 1 - 1/rho(A)^4)",
                "meaning": "finite asymptotic variance of P_t needs lambda above this (Rohr, Marelli and Fu 2010, Theorem 4)",
            }
            if one
            else None,
            "covariance": self.covariance.to_dict(),
            "p_hat": None if self.p_hat is None else self.p_hat.to_dict(),
            "region": None if self.region is None else self.region.to_dict(),
            "trace_target": None if self.trace_target is None else self.trace_target.to_dict(),
            "notes": self._notes(),
        }

    def _notes(self) -> list[str]:
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
        lines.extend(f"  note: {n}" for n in self._notes())
        return "\n".join(lines)
