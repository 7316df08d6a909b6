"""A bound on the largest chain of parallel projections, before the chains themselves are labelled.

:func:`kfio.search._pareto_proof.parallel_chains` labels every chain of
angles (modulo pi, consecutive gaps at most ``2 / _SHORT``, the last chain
joined to the first across the wrap) so that :class:`kfio.search._pareto.Front`
can count each chain's slots per group.  A set of later slots of a flat ``Q``
escapes the front only when it adds at least ``need`` slots
(:meth:`kfio.search._pareto.Front.slots_to_escape`), and every set below
``Q`` lies in one chain plus the short rows: when the largest chain plus the
short rows holds fewer than ``need`` slots, no chain escapes, whatever its
groups.  With dense sensor rows in general position most chains are single
rows, so this count settles most flats before any label is computed.

The count is an upper bound, never below the labelled chains' (so a flat
it cuts is one the labelled test cuts too, and the walk is unchanged):

* a row is short here when ``|W|^2 < (1.01 _SHORT tol)^2`` and a chain
  member when ``|W|^2 >= (0.99 _SHORT tol)^2``: every short row of
  ``parallel_chains`` is short here and every member a member (rows near
  the threshold are both, counted twice), and more members only join
  chains, never split them;
* the angle is the *diamond angle* ``p = 1 - x / (|x| + y)`` of the
  direction turned into ``y >= 0``, increasing in the angle ``theta`` on
  ``[0, pi)`` with ``dp / dtheta = 1 / (|cos| + sin)^2 <= 1``: rows within
  ``2 / _SHORT`` radians are within ``2 / _SHORT`` in ``p``, so with the
  same gap rule (and the wrap from ``p`` near 2 back to 0) every chain of
  ``parallel_chains`` lies inside one chain here.  The margin ``1e-12``
  absorbs the rounding of ``p``.
"""

from __future__ import annotations

import numpy as np

from ._pareto_proof import _SHORT


def longest_chain(W: np.ndarray, rows: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Per batch row: a bound on the most ``rows`` in one chain of :func:`~kfio.search._pareto_proof.parallel_chains`, and the short rows' count.

    A set of rows parallel for the closure holds at most the first count
    plus the second (the argument of :func:`kfio.search._pareto_proof._most_parallel`);
    the module docstring gives why the counts bound those of ``parallel_chains(W, rows, tol)``.
    """
    C, n, _ = W.shape
    x, y = W[..., 0], W[..., 1]
    flip = (y < 0) | ((y == 0) & (x < 0))
    x, y = np.where(flip, -x, x), np.abs(y)
    norm1 = np.abs(x) + y
    square = x * x + y * y
    short = rows & (square < (1.01 * _SHORT * tol) ** 2)
    member = rows & (square >= (0.99 * _SHORT * tol) ** 2)  # rows near the threshold count twice
    k = np.count_nonzero(member, axis=1)
    p = np.sort(np.where(member, 1.0 - x / np.where(norm1 > 0, norm1, 1.0), 8.0), axis=1)
    gap = 2.0 / _SHORT + 1e-12
    close = (p[:, 1:] - p[:, :-1] <= gap) & (np.arange(1, n)[None, :] < k[:, None])
    lastpos = np.maximum(k - 1, 0)
    wraps = (k > 1) & (p[:, 0] + 2.0 - p[np.arange(C), lastpos] <= gap)
    best = np.minimum(k, 1)
    rows_close = np.flatnonzero(close.any(axis=1) | wraps)
    if rows_close.size:
        # Run lengths of the close steps, the last run joined to the first across the wrap.
        cl = close[rows_close]
        m = rows_close.size
        starts = np.concatenate([np.ones((m, 1), dtype=bool), ~cl], axis=1)
        inside = np.arange(n)[None, :] < k[rows_close, None]
        starts &= inside
        chain = np.cumsum(starts, axis=1) - 1
        ids = np.where(inside, np.arange(m)[:, None] * n + chain, m * n)
        sizes = np.bincount(ids.ravel(), minlength=m * n + 1)[: m * n].reshape(m, n)
        last_chain = chain[np.arange(m), lastpos[rows_close]]
        joined = wraps[rows_close] & (last_chain > 0)
        sizes[joined, 0] += sizes[joined, last_chain[joined]]
        best[rows_close] = sizes.max(axis=1)
    return np.asarray(best), np.count_nonzero(short, axis=1)


def plane_candidates(W: np.ndarray, rows: np.ndarray, need: np.ndarray, tol: float) -> np.ndarray:
    """Batch rows (three-dimensional ``W``) for which some pivot of :func:`~kfio.search._pareto_proof.pivot_projections` passes :func:`longest_chain`.

    The pivots and members are those of ``pivot_projections(W, rows,
    need)``: pivot ``p`` among the ``k - need + 1`` longest rows, members
    the rows no longer than ``p`` (ties by position).  Sorted by length
    (longest first, stable), the members of the pivot of rank ``r`` are the
    ranks ``r .. k - 1``: the rows are gathered in that order, and the
    pivots of :data:`_RANK_BLOCK` consecutive ranks are projected together
    over the ranks from the block's first on, where the pairs of
    ``pivot_projections`` span every slot.  The projection is that of
    ``pivot_projections`` (the same plane coordinates); a batch row is
    returned when some pivot leaves a chain (with ``3 tol``) that, with the
    short rows, holds ``need`` rows.  The others cannot escape: no set of
    ``need`` rows below lies near a plane.
    """
    C, n, _ = W.shape
    size = np.where(rows, np.linalg.norm(W, axis=2), -1.0)
    order = np.argsort(-size, axis=1, kind="stable")
    k = rows.sum(axis=1)
    width = int(k.max(initial=0))
    Ws = np.take_along_axis(W, order[:, :width, None], axis=1)
    ss = np.take_along_axis(size, order[:, :width], axis=1)
    ranks = np.maximum(k - np.maximum(need, 1) + 1, 0)
    pivot = (np.arange(width)[None, :] < ranks[:, None]) & (ss > 0)
    found = np.zeros(C, dtype=bool)
    cs, rs = np.nonzero(pivot)
    block = rs // _RANK_BLOCK
    for b in np.unique(block):
        r0 = int(b) * _RANK_BLOCK
        sel = np.flatnonzero(block == b)
        for start in range(0, sel.size, _PAIRS):
            part = sel[start : start + _PAIRS]
            c, r = cs[part], rs[part]
            u = Ws[c, r] / ss[c, r][:, None]
            a = np.where(np.abs(u[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
            e1 = a - (a * u).sum(axis=1)[:, None] * u
            e1 /= np.linalg.norm(e1, axis=1)[:, None]
            e2 = np.cross(u, e1)
            V = Ws[c, r0:] @ np.stack([e1, e2], axis=2)
            col = np.arange(r0, width)[None, :]
            members = (col >= r[:, None]) & (col < k[c, None])
            best, short = longest_chain(V, members, tol)
            found[c[best + short >= need[c]]] = True
    return found


#: Consecutive length ranks of pivots projected together by :func:`plane_candidates`.
_RANK_BLOCK = 6

#: Most ``(flat, pivot)`` pairs of :func:`plane_candidates` in one piece.
_PAIRS = 1 << 12
