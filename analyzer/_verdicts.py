"""``kfio.Verdict``: the verdict strings of every report as one string enum.

A member *is* its JSON text (``Verdict.STABLE == "stable"``), so comparing a
report's ``verdict`` with a plain string keeps working and the JSON of every
report is unchanged; typed code compares with the member instead.
"""

from __future__ import annotations

from enum import StrEnum


class Verdict(StrEnum):
    """The verdict of a report, as it appears in the JSON.

    ``STABLE``, ``BOUNDARY`` and ``UNSTABLE`` are the exact verdict of Rohr,
    Marelli and Fu (2014), Theorem 1 (``|alpha_k|^2 sigma_k < 1`` for every
    FMO block, ``= 1`` for the worst, ``> 1`` for some block):
    ``kfio.analyze(...).verdict``, each block's, and the exact verdict beside
    a simulation.  ``kfio.bounds(...).verdict`` is the verdict of the
    Sinopoli et al. (2004) bounds at the operating point: ``STABLE``,
    ``UNSTABLE`` or ``UNDECIDED`` (the bounds are evidence, not the verdict).

    Examples
    --------
    >>> Verdict("boundary") is Verdict.BOUNDARY, Verdict.STABLE == "stable", str(Verdict.UNSTABLE)
    (True, True, 'unstable')
    """

    STABLE = "stable"
    BOUNDARY = "boundary"
    UNSTABLE = "unstable"
    UNDECIDED = "undecided"

    @classmethod
    def of_sign(cls, sign: int) -> Verdict:
        """The verdict of the sign of ``rate - 1`` (Theorem 1): ``-1`` stable, ``0`` boundary, ``1`` unstable."""
        return (cls.STABLE, cls.BOUNDARY, cls.UNSTABLE)[sign + 1]

    def __repr__(self) -> str:
        # reports and tuples print the JSON text, so a verdict reads alike everywhere: ('stable', '9/25', 0.5)
        return repr(self.value)


__all__ = ["Verdict"]
