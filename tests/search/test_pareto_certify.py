"""The front proof's certificate (:meth:`FrontProof._certify`): the same front and representative sets.

Once the rotation walk of :class:`kfio.search._pareto_proof.FrontProof` has
gone long without a change of the front, a second proof with the affine
walk over a copy of the front either changes nothing (the front is final:
the proof stops) or gives up at its first change (the proof goes on, and
tries again later).  The representative sets are the first ones offered
with each vector, so the answer must be the one of the proof without the
certificate, set for set.  Checked here, with the walk handing its flats
over often so that certificates are tried early, also before the front
is final:

* cyclotomic bench blocks and random blocks (whose real rows give the
  unit ``-1``): the representative sets equal those without the
  certificate, the vectors those of every shift orbit;
* certificates were tried, some showed the front final and some gave up,
  and none offered a set to the front itself.
"""

from __future__ import annotations

import numpy as np
import pytest

import kfio.search._pareto as pareto
import kfio.search._pareto_proof as proof
from kfio._budget import Budget
from kfio.search._blind import Margins, SlotSpace

from support.blind_blocks import assert_front_matches_enumeration, bench_block, random_block

SEED = 20261203


def answer(space: SlotSpace, certify: bool, monkeypatch: pytest.MonkeyPatch) -> list[bytes]:
    monkeypatch.setattr(proof, "CERTIFY", certify)
    res = pareto.pareto_search(space, Budget(max_steps=5_000_000), Margins(space.tol))
    return [m.tobytes() for m in res.maximal]


class Tally:
    """Wraps :meth:`FrontProof._certify` to count the certificates tried, those that showed the front final, and the others."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.tried = self.complete = self.premature = 0
        certify = proof.FrontProof._certify
        tally = self

        def _certify(self: proof.FrontProof) -> None:
            before = self.front.vectors
            try:
                certify(self)
            except proof._Complete:
                tally.complete += 1
                raise
            finally:
                tally.tried += bool(self.certifiable)
                assert self.front.vectors is before  # a certificate never offers to the front itself
            tally.premature += bool(self.certifiable)

        monkeypatch.setattr(proof.FrontProof, "_certify", _certify)


CASES = [((15,), True), ((21,), True), ((3, 4), True), ((4, 5), True), ((3, 7), True), ((4, 9), True), ((20,), False)]


@pytest.mark.parametrize("factor", [0, 2])
@pytest.mark.parametrize(("factors", "dense"), CASES)
def test_certificate_keeps_the_answer_on_cyclotomic_blocks(
    factors: tuple[int, ...], dense: bool, factor: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``factor = 0``: tried after the first hand-over, often before the front is final."""
    monkeypatch.setattr(pareto, "PROBE_FLATS", 0)
    monkeypatch.setattr(proof, "_ONLINE_NODES", 16)
    monkeypatch.setattr(proof, "_CERTIFY_AFTER", 1)
    monkeypatch.setattr(proof, "_CERTIFY_FACTOR", factor)
    space = SlotSpace.from_block(bench_block(factors, dense=dense))
    slow = answer(space, False, monkeypatch)
    tally = Tally(monkeypatch)
    fast = answer(space, True, monkeypatch)
    assert fast == slow
    assert tally.complete <= 1 and tally.tried == tally.complete + tally.premature
    if factor == 0 and dense:
        assert tally.tried >= 1  # dense rows: the walk makes a hand-over, and affine maps exist


def test_certificate_stops_some_proofs_early(monkeypatch: pytest.MonkeyPatch) -> None:
    """Over the bench blocks, some certificates show the front final (the proof stops) and some give up (it goes on)."""
    monkeypatch.setattr(pareto, "PROBE_FLATS", 0)
    monkeypatch.setattr(proof, "_ONLINE_NODES", 16)
    monkeypatch.setattr(proof, "_CERTIFY_AFTER", 1)
    monkeypatch.setattr(proof, "_CERTIFY_FACTOR", 0)
    tally = Tally(monkeypatch)
    for factors, dense in CASES:
        answer(SlotSpace.from_block(bench_block(factors, dense=dense)), True, monkeypatch)
    assert tally.complete >= 1
    assert tally.premature >= 1


@pytest.mark.parametrize("i", range(40))
def test_certificate_keeps_the_answer_on_random_blocks(i: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng([SEED, 8800 + i])
    space = SlotSpace.from_block(random_block(rng, int(rng.integers(4, 13)), 2, rows=1, real=i % 4 != 0))
    monkeypatch.setattr(pareto, "PROBE_FLATS", 0)
    monkeypatch.setattr(proof, "_ONLINE_NODES", 1)
    monkeypatch.setattr(proof, "_CERTIFY_AFTER", 1)
    monkeypatch.setattr(proof, "_CERTIFY_FACTOR", i % 3)
    slow = answer(space, False, monkeypatch)
    fast = answer(space, True, monkeypatch)
    assert fast == slow
    res = pareto.pareto_search(space, Budget(max_steps=5_000_000), Margins(space.tol))
    assert_front_matches_enumeration(space, res.maximal)
