"""The exact Gilbert-Elliott stability boundary as ordered polylines, for drawing.

The boundary is where the largest rate ``max_F beta rho_F(p, q)^(1/N)`` of
:meth:`kfio.design._ge_region.GeStructure.max_rate_float` crosses 1 (Rohr,
Marelli and Fu (2014), Theorem 1, on the Gilbert-Elliott family).  Marching
squares on a mesh of the (p, q) square says which mesh edges the curve
crosses and how the crossings connect; each crossing is then moved onto the
curve by bisection along its edge (a line of fixed ``p`` or fixed ``q``) to
about ``1e-15``.  Every vertex is therefore a point of the boundary itself,
and the order of the vertices follows the curve: a curve that turns back in
``p`` (a fold) is drawn as the fold it is, never as points sorted by one
coordinate.  ``kfio analyze --ge-plot`` and the plot of a (p, q) sweep draw
these same lines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._ge_region import GeStructure

#: Mesh nodes per axis on which the drawn boundary is traced.
BOUNDARY_MESH = 101
#: The mesh spans ``[EDGE, 1 - EDGE]``: the rates 0 and 1 are degenerate channels.
EDGE = 1e-6
_BISECTIONS = 60

Edge = tuple[str, int, int]


@dataclass(frozen=True)
class BoundaryLine:
    """One connected piece of the boundary, its vertices in order along the curve.

    Attributes
    ----------
    q, p:
        Recovery and failure rates of the vertices (floats on the curve).
    pattern:
        Index into :attr:`GeStructure.patterns` of the (block, blind set) whose
        rate is the largest at each vertex: the piece of the curve it lies on.
    closed:
        The line is a loop (its last vertex joins its first).
    """

    q: tuple[float, ...]
    p: tuple[float, ...]
    pattern: tuple[int, ...]
    closed: bool


def _unstable(structure: GeStructure, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    rate, _ = structure.max_rate_float(p, q)
    return np.asarray(rate >= 1.0)


def _cell_segments(side: np.ndarray, centre: np.ndarray) -> list[tuple[Edge, Edge]]:
    """Marching squares: the pairs of crossed edges joined inside each cell.

    ``side[i, j]`` is the side of the curve at ``p = t[i]``, ``q = t[j]``; edge
    ``("q", i, j)`` joins nodes ``(i, j)`` and ``(i, j + 1)`` (``q`` varies),
    edge ``("p", i, j)`` joins ``(i, j)`` and ``(i + 1, j)``.
    """
    out: list[tuple[Edge, Edge]] = []
    n = side.shape[0]
    for i in range(n - 1):
        for j in range(n - 1):
            c0, c1, c2, c3 = side[i, j], side[i, j + 1], side[i + 1, j + 1], side[i + 1, j]
            if c0 == c1 == c2 == c3:
                continue
            e01, e12, e23, e30 = ("q", i, j), ("p", i, j + 1), ("q", i + 1, j), ("p", i, j)
            crossed = [e for e, (a, b) in zip((e01, e12, e23, e30), ((c0, c1), (c1, c2), (c2, c3), (c3, c0))) if a != b]
            if len(crossed) == 2:
                out.append((crossed[0], crossed[1]))
            elif centre[i, j] == c0:  # a saddle: corners 0 and 2 connect through the centre
                out.extend([(e01, e12), (e23, e30)])
            else:
                out.extend([(e30, e01), (e12, e23)])
    return out


def _chains(segments: list[tuple[Edge, Edge]]) -> list[tuple[list[Edge], bool]]:
    """Link segments that share an edge into chains (open ones first from their ends, then loops)."""
    links: dict[Edge, list[Edge]] = {}
    for a, b in segments:
        links.setdefault(a, []).append(b)
        links.setdefault(b, []).append(a)
    seen: set[Edge] = set()
    out: list[tuple[list[Edge], bool]] = []
    starts = sorted(e for e, nb in links.items() if len(nb) == 1) + sorted(links)
    for start in starts:
        if start in seen:
            continue
        chain, prev, here = [start], None, start
        seen.add(start)
        while True:
            nxt = [e for e in links[here] if e != prev and e not in seen]
            if not nxt:
                break
            prev, here = here, nxt[0]
            chain.append(here)
            seen.add(here)
        closed = len(chain) > 2 and chain[0] in links[chain[-1]]
        out.append((chain, closed))
    return out


def _bisect(structure: GeStructure, t: np.ndarray, side: np.ndarray, edges: list[Edge]) -> np.ndarray:
    """``(q, p)`` on the curve for every crossed edge, by bisection along the edge (vectorized)."""
    var = np.array([e[0] == "q" for e in edges])
    i = np.array([e[1] for e in edges])
    j = np.array([e[2] for e in edges])
    fixed = np.where(var, t[i], t[j])
    lo = np.where(var, t[j], t[i])
    last = len(t) - 1  # np.where reads both branches: keep the unused one in range
    hi = np.where(var, t[np.minimum(j + 1, last)], t[np.minimum(i + 1, last)])
    lo_side = side[i, j]
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        s = _unstable(structure, np.where(var, fixed, mid), np.where(var, mid, fixed))
        same = s == lo_side
        lo = np.where(same, mid, lo)
        hi = np.where(same, hi, mid)
    x = 0.5 * (lo + hi)
    return np.stack([np.where(var, x, fixed), np.where(var, fixed, x)], axis=1)


def boundary_lines(structure: GeStructure, mesh: int = BOUNDARY_MESH) -> tuple[BoundaryLine, ...]:
    """The boundary ``max_F beta rho_F(p, q)^(1/N) = 1`` in the (p, q) square, as ordered polylines.

    Parameters
    ----------
    structure:
        The binding patterns of every block (:func:`kfio.design._ge_region.ge_structure`).
    mesh:
        Nodes per axis of the tracing mesh (on ``[EDGE, 1 - EDGE]``).

    Returns
    -------
    tuple of BoundaryLine
        Each vertex satisfies the boundary equation to the float precision of
        the rate (bisection along a mesh edge); consecutive vertices are
        neighbours along the curve.  Empty when the whole square is on one side.

    Examples
    --------
    ``A = (5/4) diag(1, -1)``, ``C = [1 1]``: ``(25/16)^2 ((1 - q)^2 + p q) = 1``.

    >>> from kfio import load_request, analyze
    >>> r = analyze(load_request('{"system": {"A": [["5/4", 0], [0, "-5/4"]], "C": [[1, 1]]}, '
    ...     '"channel": {"model": "gilbert_elliott", "failure_rate": "1/4", "recovery_rate": "1/2"}}'))
    >>> (line,) = boundary_lines(GeStructure(r.gilbert_elliott.patterns))
    >>> round(max(line.p), 3), max(abs((25 / 16) ** 2 * ((1 - q) ** 2 + p * q) - 1) for q, p in zip(line.q, line.p)) < 1e-12
    (0.463, True)
    """
    t = np.linspace(EDGE, 1 - EDGE, mesh)
    pp, qq = np.meshgrid(t, t, indexing="ij")
    side = _unstable(structure, pp, qq)
    mid = 0.5 * (t[:-1] + t[1:])
    pc, qc = np.meshgrid(mid, mid, indexing="ij")
    centre = _unstable(structure, pc, qc)
    out = []
    for chain, closed in _chains(_cell_segments(side, centre)):
        qp = _bisect(structure, t, side, chain)
        _, pattern = structure.max_rate_float(qp[:, 1], qp[:, 0])
        out.append(
            BoundaryLine(
                tuple(float(v) for v in qp[:, 0]),
                tuple(float(v) for v in qp[:, 1]),
                tuple(int(k) for k in np.atleast_1d(pattern)),
                closed,
            )
        )
    return tuple(out)


__all__ = ["BOUNDARY_MESH", "BoundaryLine", "boundary_lines"]
