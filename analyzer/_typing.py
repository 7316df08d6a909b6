"""The argument types of the Python API, for type checkers (``kfio.NumberLike``, ``kfio.MatrixLike``, ...).

They describe what :class:`kfio.System`, the channel builders and the
``budget`` arguments accept; the validator (:mod:`kfio.model._request`)
decides the rest at run time with a message naming the argument.  Importing
this module imports neither NumPy nor anything else of kfio's at run time.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol, SupportsFloat, SupportsIndex, TypeAlias, Union

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from ._budget import Budget
    from .model._types import MarkovChannel, PerSensorChannel, Sensor

#: A real number: ``int``, ``float``, ``Fraction``, a NumPy scalar, or its exact text (``"11/10"``, ``"1.1e-3"``).
#: A float means its shortest decimal text (``1.1`` is ``11/10``).
NumberLike: TypeAlias = Union[SupportsFloat, SupportsIndex, str]

#: A matrix: rows of :data:`NumberLike` (lists or tuples), or a real NumPy array.
MatrixLike: TypeAlias = Union[Sequence[Sequence[NumberLike]], "NDArray[Any]"]

#: A channel: :func:`kfio.bernoulli`, :func:`kfio.gilbert_elliott`, :func:`kfio.markov`,
#: :func:`kfio.per_sensor`, or a channel's JSON object.
ChannelLike: TypeAlias = Union["MarkovChannel", "PerSensorChannel", Mapping[str, Any]]

#: A budget: seconds (``options.time_budget_s``) or a :class:`kfio.Budget`.
BudgetLike: TypeAlias = Union["Budget", NumberLike]

#: Sensors of a :class:`kfio.System`: ``{"gps": [0], "imu": [1, 2]}`` or ``[{"name": ..., "rows": [...]}]``.
SensorsLike: TypeAlias = Union[Mapping[str, Sequence[int]], Sequence[Mapping[str, Any]], Sequence["Sensor"]]


class StateSpaceLike(Protocol):
    """A python-control ``StateSpace`` with a discrete time base, as kfio reads it: ``A``, ``C`` (``B`` for a
    loop) and ``dt``.  kfio never imports python-control; any object with these attributes is taken."""

    @property
    def A(self) -> Any: ...

    @property
    def B(self) -> Any: ...

    @property
    def C(self) -> Any: ...

    @property
    def dt(self) -> Any: ...


__all__ = ["BudgetLike", "ChannelLike", "MatrixLike", "NumberLike", "SensorsLike", "StateSpaceLike"]
