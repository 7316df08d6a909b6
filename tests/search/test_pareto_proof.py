"""Completing a two-sensor front from the big flats of one sensor, against enumeration and brute force.

:mod:`kfio.search._pareto_proof` takes over from the walk over both
groups once it has expanded ``PROBE_FLATS`` flats (by default none: the
proof builds the whole front from the one-group extremes).  With no probe,
or a short one, the answer must equal:

* the undominated vectors of every shift orbit (:func:`enumerate_orbits`);
* the undominated vectors of all subsets of tiny blocks;
* per piece: the largest set of rows on a hyperplane by all subsets, and
  the big flats of one group by closing all subsets.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import kfio.search._pareto as pareto
import kfio.search._pareto_proof as proof
from kfio._budget import Budget
from kfio.search._blind import Margins, SlotSpace
from kfio.search._blind_batch import enumerate_orbits, real_space
from kfio.search._pareto import Front, group_space, pareto_search
from kfio.sigma._sigma import undominated

from support.blind_blocks import (
    assert_front_matches_enumeration,
    assert_maximal_blind,
    bench_block,
    random_block,
    subsets_front,
    vectors,
)

SEED = 20261203


def two_group_case(i: int) -> SlotSpace:
    rng = np.random.default_rng([SEED, 7000 + i])
    N0 = int(rng.integers(2, 13))
    return SlotSpace.from_block(random_block(rng, N0, 2, rows=1 + (i % 5 == 4), real=i % 3 != 0))


@pytest.mark.parametrize("online", [4096, 1])
@pytest.mark.parametrize("probe", [0, 5])
@pytest.mark.parametrize("i", range(60))
def test_proof_equals_undominated_orbits(i: int, probe: int, online: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """``online = 1``: the walk hands its flats to the checks after every batch, and may raise its size mid-walk."""
    monkeypatch.setattr(pareto, "PROBE_FLATS", probe)
    monkeypatch.setattr(proof, "_ONLINE_NODES", online)
    space = two_group_case(i)
    front = pareto_search(space, Budget(max_steps=2_000_000), Margins(space.tol))
    assert_front_matches_enumeration(space, front.maximal)


@pytest.mark.parametrize("i", range(30))
def test_proof_equals_all_subsets(i: int, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(pareto, "PROBE_FLATS", 0)
    rng = np.random.default_rng([SEED, 8000 + i])
    space = SlotSpace.from_block(random_block(rng, int(rng.integers(2, 6)), 2, rows=1, real=i % 2 == 0))
    front = pareto_search(space, Budget(max_steps=100_000), Margins(space.tol))
    assert vectors(space, front.maximal) == subsets_front(space)


@pytest.mark.slow
@pytest.mark.parametrize("factors", [(15,), (3, 5), (3, 4)])
@pytest.mark.parametrize("probe", [0, 50])
def test_dense_bench_blocks_equal_the_walk(
    factors: tuple[int, ...], probe: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Dense rows on cyclotomic blocks: the proof (after a short walk, or none) equals the walk run to its end."""
    space = SlotSpace.from_block(bench_block(factors, dense=True))
    monkeypatch.setattr(pareto, "PROBE_FLATS", None)
    walked = pareto_search(space, Budget(max_steps=10_000_000), Margins(space.tol))
    monkeypatch.setattr(pareto, "PROBE_FLATS", probe)
    proved = pareto_search(space, Budget(max_steps=10_000_000), Margins(space.tol))
    assert vectors(space, proved.maximal) == vectors(space, walked.maximal)
    for m in proved.maximal:
        assert_maximal_blind(space, m)


def test_one_flat_a_batch_gives_the_same_front(monkeypatch: pytest.MonkeyPatch) -> None:
    """The memory bound on a batched hyperplane walk (one flat a walk at its tightest) changes no answer."""
    space = SlotSpace.from_block(bench_block((15,), dense=True))
    batched = pareto_search(space, Budget(max_steps=10_000_000), Margins(space.tol))
    monkeypatch.setattr(proof, "_BATCH_PREFIXES", 1)
    single = pareto_search(space, Budget(max_steps=10_000_000), Margins(space.tol))
    assert vectors(space, single.maximal) == vectors(space, batched.maximal)
    assert single.checked == batched.checked


@pytest.mark.parametrize("i", range(30))
def test_a_falling_threshold_walks_again(i: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Group 1's first walk is told a size too high (all it could hold); once told the truth it walks again.

    With separate walks (no shared matroid) the list of group 1 stays cut at
    the false size unless a threshold below the size walked makes it walk
    again: the front must still be every undominated vector.
    """
    monkeypatch.setattr(pareto, "PROBE_FLATS", 0)
    monkeypatch.setattr(proof, "shared_matroid", lambda a, b, margins: None)
    space = two_group_case(i)
    group1 = group_space(real_space(space), 1).rows
    true_threshold, true_walk = proof.threshold, proof.big_flats
    walks: list[int] = []

    def threshold(front: Front, side: int, most: tuple[int, int]) -> int | None:
        T = true_threshold(front, side, most)
        return most[1] if side == 1 and T is not None and not walks else T

    def big_flats(sub: SlotSpace, T: int, *args, **kwargs):  # type: ignore[no-untyped-def]
        out = true_walk(sub, T, *args, **kwargs)
        if sub.rows.shape == group1.shape and np.array_equal(sub.rows, group1):
            walks.append(T)
        return out

    monkeypatch.setattr(proof, "threshold", threshold)
    monkeypatch.setattr(proof, "big_flats", big_flats)
    front = pareto_search(space, Budget(max_steps=2_000_000), Margins(space.tol))
    assert_front_matches_enumeration(space, front.maximal)
    if len(walks) > 1:
        assert walks[-1] < walks[0]


def configuration(i: int) -> np.ndarray:
    """``N x p x k`` rows with coincidences: small integers, a planted hyperplane, parallel and zero rows."""
    rng = np.random.default_rng([SEED, 9000 + i])
    k, N, p = int(rng.integers(2, 6)), int(rng.integers(4, 11)), 1 + (i % 4 == 3)
    P = rng.integers(-2, 3, size=(N, p, k)).astype(float)
    normal = rng.integers(-2, 3, size=k).astype(float)
    if normal.any():
        planted = rng.random(N) < 0.5
        P[planted] -= np.outer(P[planted].reshape(-1, k) @ normal, normal).reshape(-1, p, k) / (normal @ normal)
    if N > 5:
        P[1] = 3 * P[0]
        P[2] = 0
    if i % 2:
        P = P @ np.linalg.qr(rng.standard_normal((k, k)))[0]  # no longer integers: round-off in every decision
    return P


def most_zeros_by_subsets(P: np.ndarray) -> int:
    N, p, k = P.shape
    return max(
        len(sub)
        for r in range(N + 1)
        for sub in itertools.combinations(range(N), r)
        if np.linalg.matrix_rank(P[list(sub)].reshape(-1, k), tol=1e-8) < k
    )


@pytest.mark.parametrize("route", ["hyperplanes", "closures"])
@pytest.mark.parametrize("i", range(60))
def test_most_zeros_vector_against_all_subsets(i: int, route: str, monkeypatch: pytest.MonkeyPatch) -> None:
    P = configuration(i)
    if route == "closures":
        monkeypatch.setattr(proof, "_MOST_SUBSETS", 0)
    best = most_zeros_by_subsets(P)
    margins = Margins(tol=1e-9)
    for m in range(1, P.shape[0] + 1):
        x = proof.most_zeros_vector(P, m, Budget(max_steps=100_000), margins)
        assert (x is not None) == (m <= best), (m, best)
        if x is not None:
            assert np.linalg.norm(x) == pytest.approx(1.0)
            assert int((np.linalg.norm(P @ x, axis=1) <= 1e-9).sum()) >= m


@pytest.mark.slow
@pytest.mark.parametrize("k", [2, 3, 4, 5])
def test_most_zeros_vectors_batch_equals_all_subsets(k: int) -> None:
    """One batched walk over 12 blocks of one shape, each asked for a different count, against all subsets."""
    rng = np.random.default_rng([SEED, 9500 + k])
    N = 10
    P = rng.integers(-2, 3, size=(12, N, 1, k)).astype(float)
    for b in range(12):
        normal = rng.integers(-2, 3, size=k).astype(float)
        if normal.any() and b % 3:  # plant a hyperplane holding about half the rows
            planted = rng.random(N) < 0.6
            P[b, planted] -= np.outer(P[b, planted, 0] @ normal, normal)[:, None, :] / (normal @ normal)
        if b % 4 == 1:
            P[b, 3] = 0
    P = P @ np.linalg.qr(rng.standard_normal((k, k)))[0]
    best = [most_zeros_by_subsets(P[b]) for b in range(12)]
    margins = Margins(tol=1e-9)
    for shift in (-1, 0, 1):
        m = np.array([max(1, min(N, best[b] + shift)) for b in range(12)])
        answers = proof.most_zeros_vectors(P, m, Budget(max_steps=100_000), margins)
        for b, x in enumerate(answers):
            assert (x is not None) == (m[b] <= best[b]), (b, m[b], best[b])
            if x is not None:
                assert int((np.linalg.norm(P[b] @ x, axis=1) <= 1e-9).sum()) >= m[b]


def flats_by_subsets(space: SlotSpace, T: int) -> set[tuple[int, ...]]:
    """Orbit keys of the closures of all subsets with rank < L and at least ``T`` slots."""
    S, L = space.size, space.n_columns
    rows = space.rows.reshape(S, -1, L)
    out = set()
    for r in range(S + 1):
        for sub in itertools.combinations(range(S), r):
            M = rows[list(sub)].reshape(-1, L)
            if M.shape[0] and np.linalg.matrix_rank(M, tol=1e-8) == L:
                continue
            _, sv, vh = np.linalg.svd(M if M.shape[0] else np.zeros((1, L)))
            K = vh[int((sv > 1e-8).sum()) :].conj().T
            closed = np.linalg.norm(rows @ K, axis=(1, 2)) <= 1e-8
            if closed.sum() >= T:
                out.add(space.orbit_key(closed))
    return out


@pytest.mark.parametrize("real", [False, True])
@pytest.mark.parametrize("i", range(20))
def test_big_flats_are_every_closure_of_enough_slots(i: int, real: bool) -> None:
    rng = np.random.default_rng([SEED, 9500 + i])
    space = group_space(SlotSpace.from_block(random_block(rng, int(rng.integers(3, 10)), 2, rows=1, real=real)), 0)
    space = real_space(space)
    T = int(rng.integers(1, 4))
    found, kept = proof.big_flats(space, T, Budget(max_steps=100_000), Margins(space.tol))
    assert kept == T
    assert {space.orbit_key(m) for m, _ in found} == flats_by_subsets(space, T)
    for m, K in found:
        if K is None:
            continue  # a maximal flat: its kernel is taken when it is checked
        assert np.linalg.norm(space.rows[m].reshape(-1, space.n_columns) @ K) <= 1e-8
        assert K.shape[1] == space.n_columns - np.linalg.matrix_rank(
            space.rows[m].reshape(-1, space.n_columns), tol=1e-8
        )


def front_of(counts: list[tuple[int, int]]) -> Front:
    """A front of blind counts ``(group 0, group 1)`` over six phases."""
    space = SlotSpace(n_phases=6, n_groups=2, rows=np.zeros((12, 1, 2)), tol=1e-9)
    front = Front(space, np.array([1, 1]))
    for a, b in counts:
        mask = np.zeros((6, 2), dtype=bool)
        mask[:a, 0] = True
        mask[:b, 1] = True
        front.offer(mask.reshape(1, -1))
    return front


def test_threshold_assigns_every_beyond_point_to_one_side() -> None:
    """Front (blind counts) (0, 5), (3, 3), (5, 0), at most 5 a group: minimal beyond points (1..3, 4) and (4..5, 1)."""
    front = front_of([(0, 5), (3, 3), (5, 0)])
    assert proof.threshold(front, 0, (5, 5)) == 4  # (4, 1) and (4, 4): a >= b
    assert proof.threshold(front, 1, (5, 5)) == 4  # (3, 4): group 1 holds at least 4
    assert proof.threshold(front, 0, (3, 3)) is None  # nothing beyond the front fits in three slots a group
    assert proof.threshold(front, 1, (3, 3)) is None


def test_threshold_leaves_group_1_only_what_group_0_does_not_check() -> None:
    """Front (0, 5), (2, 4), (4, 2), (5, 0): group 0 checks x >= 3 ((3, 3) is beyond); x <= 2 needs y >= 5.

    The point (4, 3) seen from group 1 (y = 4 > x = 3) needs no check from
    group 1: group 0 already checks every set with x >= 3.
    """
    front = front_of([(0, 5), (2, 4), (4, 2), (5, 0)])
    assert proof.threshold(front, 0, (5, 5)) == 3
    assert proof.threshold(front, 1, (5, 5)) == 5
    # Brute force over every count vector: each one beyond the front is checked from a side.
    T0, T1 = proof.threshold(front, 0, (5, 5)), proof.threshold(front, 1, (5, 5))
    for x in range(6):
        for y in range(6):
            beyond = not any(x <= a and y <= b for a, b in [(0, 5), (2, 4), (4, 2), (5, 0)])
            assert not beyond or x >= T0 or y >= T1, (x, y)


def test_shared_matroid_is_the_column_scaling_between_groups() -> None:
    """Dense rows: group 1 is group 0 times diag(c_1 / c_0); a zero entry in one group only breaks that."""
    space = SlotSpace.from_block(bench_block((15,), dense=True))
    a, b = group_space(space, 0), group_space(space, 1)
    M = proof.shared_matroid(a, b, Margins(space.tol))
    assert M is not None
    assert np.allclose(M, np.diag(np.diag(M)), atol=1e-12), "in eigen-coordinates the map is a column scaling"
    assert np.allclose(a.rows @ M, b.rows, atol=1e-12)
    rows = b.rows.copy()
    rows[:, :, 0] = 0  # group 1 blind to the first column: its flats differ from group 0's
    assert proof.shared_matroid(a, SlotSpace(b.n_phases, 1, rows, b.tol), Margins(space.tol)) is None


@pytest.mark.parametrize("i", range(30))
def test_shared_flats_give_the_front_of_separate_walks(i: int, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(pareto, "PROBE_FLATS", 0)
    space = two_group_case(i)
    shared = pareto_search(space, Budget(max_steps=2_000_000), Margins(space.tol))
    monkeypatch.setattr(proof, "shared_matroid", lambda a, b, margins: None)
    separate = pareto_search(space, Budget(max_steps=2_000_000), Margins(space.tol))
    assert vectors(space, shared.maximal) == vectors(space, separate.maximal)


@pytest.mark.parametrize(("factors", "dense"), [((15,), True), ((21,), True), ((3, 5), False), ((3, 4, 5), False)])
def test_big_flats_bounds_cut_no_flat_of_enough_slots(factors: tuple[int, ...], dense: bool) -> None:
    """On cyclotomic blocks (many parallel classes with rows e_1): the flats of the bounded walk are those of the whole walk.

    The walk with ``T = 0`` cuts nothing; with ``T`` it cuts by hulls and,
    below planes of kernels, by the largest parallel class that holds no
    slot the flat misses up to its core.
    """
    space = real_space(group_space(SlotSpace.from_block(bench_block(factors, dense=dense)), 0))
    margins = Margins(space.tol)
    every, _ = proof.big_flats(space, 0, Budget(max_steps=10_000_000), margins)
    sizes = sorted({int(m.sum()) for m, _ in every})
    for T in sizes[len(sizes) // 3 :: 2]:
        found, _ = proof.big_flats(space, T, Budget(max_steps=10_000_000), margins)
        assert {m.tobytes() for m, _ in found} == {m.tobytes() for m, _ in every if m.sum() >= T}, T


def test_most_parallel_drops_only_classes_that_surely_hold_a_poison_row() -> None:
    """Later rows a, b parallel (angle 0.3); a poison row 1.5e-4 rad away is in their chain of angles, not their class.

    The bound must still count a and b; a poison row parallel to them (the
    chain is tight) drops the class, and a later row elsewhere then counts 1.
    """
    tol = 1e-9
    angles = np.array([0.3, 0.3, 0.3 + 1.5e-4, 2.0])
    W = np.stack([np.cos(angles), np.sin(angles)], axis=1)[None, :, :] * np.array([1.0, 2.0, 1.0, 1.0])[None, :, None]
    later = np.array([[True, True, False, True]])
    poison = ~later
    assert proof._most_parallel(W, later, tol, poison=poison)[0] == 2
    W_tight = W.copy()
    W_tight[0, 2] = 3 * W[0, 0]  # the poison row now parallel to a and b
    assert proof._most_parallel(W_tight, later, tol, poison=poison)[0] == 1
    assert proof._most_parallel(W_tight, later, tol)[0] == 2  # without poison: the class of a and b
    # Across the wrap (angles near 0 and near pi are parallel): one class of three.
    wrap = np.array([1e-13, np.pi - 1e-13, np.pi - 2e-13])
    Ww = np.stack([np.cos(wrap), np.sin(wrap)], axis=1)[None, :, :]
    assert proof._most_parallel(Ww, np.ones((1, 3), dtype=bool), tol)[0] == 3


def test_big_flats_size_never_falls_during_the_walk() -> None:
    """``on_found`` answering a smaller size than before leaves ``T`` where it was; ``None`` lifts it past every flat."""
    space = group_space(SlotSpace.from_block(bench_block((15,), dense=True)), 0)
    found = proof._BigFlats(space, 2, on_found=lambda batch: answers.pop(0))
    answers = [5, 3, None]
    for T in (5, 5, space.size + 1):
        found.pending.append((np.ones(space.size, dtype=bool), None))
        found.flush()
        assert found.T == T


def largest_flats(groups: list[SlotSpace], margins: Margins) -> list[dict[int, np.ndarray]]:
    """The flat of most slots of each rank of each group, from every flat of the closure walk."""
    largest: list[dict[int, np.ndarray]] = [{}, {}]
    for g, sub in enumerate(groups):
        found, _ = proof.big_flats(sub, 0, Budget(max_steps=1_000_000), margins)
        proof.largest_by_rank(found, sub.n_columns, largest[g])
    return largest


@pytest.mark.parametrize("i", range(30))
def test_generic_front_seeds_are_attained(i: int) -> None:
    """Every seeded set is maximal blind and its vector lies under the true front (the enumeration's)."""
    space = two_group_case(i)
    margins = Margins(space.tol)
    groups = [group_space(space, g) for g in (0, 1)]
    front = Front(space, np.zeros(2, dtype=int))
    proof.seed_generic(space, front, groups, largest_flats(groups, margins), margins)
    every = enumerate_orbits(space, Budget(max_steps=2_000_000), Margins(space.tol))
    truth = vectors(space, undominated(space, list(every.maximal)))
    for m in front.masks:
        assert_maximal_blind(space, m)
    for z in vectors(space, front.masks):
        assert any(all(t <= x for t, x in zip(tz, z)) for tz in truth), (z, truth)


def test_generic_front_of_period_21_is_the_whole_front() -> None:
    """Period 21, dense rows: the generic front (g = 0, 1, 3, 4, 6, 7, 9, 10, 12, 13, 15, 17) is all of it.

    ``g(r)``, the most phases of one sensor whose rows have rank ``r``, comes
    from a brute force over all ``2^21`` subsets of the phases (numpy ranks,
    about four minutes, so not in the suite); the seeds here come from the
    closure walk's flats, an independent route.
    """
    space = SlotSpace.from_block(bench_block((21,), dense=True))
    margins = Margins(space.tol)
    groups = [group_space(space, g) for g in (0, 1)]
    front = Front(space, np.zeros(2, dtype=int))
    proof.seed_generic(space, front, groups, largest_flats(groups, margins), margins)
    g = [0, 1, 3, 4, 6, 7, 9, 10, 12, 13, 15, 17]
    assert vectors(space, front.masks) == sorted((21 - g[r], 21 - g[11 - r]) for r in range(12))


@pytest.mark.slow
@pytest.mark.parametrize("i", range(12))
def test_front_proof_invariant_passed_flats_hold_nothing_beyond_the_front(i: int) -> None:
    """:class:`FrontProof`'s invariant, by brute force: every passed flat ``F`` of a side holds no
    kernel vector zeroing ``B(|F|) + 1`` slots of the other group (all subsets of those slots tried);
    a second :meth:`run` checks no flat and changes nothing; the passes are within the finite bound."""
    rng = np.random.default_rng([SEED, 9900 + i])
    space = SlotSpace.from_block(random_block(rng, int(rng.integers(2, 7)), 2, rows=1, real=i % 2 == 0))
    margins = Margins(space.tol)
    budget = Budget(max_steps=200_000)
    lower, seeds = pareto.group_extremes(space, budget, margins)
    front = Front(space, lower)
    if seeds:
        front.offer(np.array(seeds))
    run = proof.FrontProof(real_space(space), front, budget, margins)
    checked = run.run()
    assert vectors(space, tuple(front.masks)) == subsets_front(space)
    assert len(run.passes) <= (run.most[0] + 1) * (run.most[1] + 1)
    before = front.vectors.copy()
    assert run.run() == checked  # everything passed stays passed: nothing is checked again
    assert np.array_equal(before, front.vectors)
    counts = {side: proof._blind_counts(front, side) for side in (0, 1)}
    for side in (0, 1):
        own, other = run.groups[side], run.groups[1 - side]
        for key in run.passed[side]:
            mask = np.frombuffer(key, dtype=bool).reshape(own.rows.shape[:-2] if own.rows.ndim > 2 else (-1,))
            K = proof._kernel(own.rows[mask].reshape(-1, own.n_columns), margins)
            if K.shape[1] == 0:
                continue
            m = proof._beyond_floor(counts[side], int(mask.sum())) + 1
            P = other.rows.reshape(other.rows.shape[0], -1, other.n_columns) @ K
            assert most_zeros_by_subsets(P) < m, (side, int(mask.sum()), m)
