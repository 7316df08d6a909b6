"""kfio's JSON contract, in one place: one encoder and one view per report class.

* :func:`encode` holds every mechanical rule (finite floats or ``null``, NumPy
  arrays and scalars, complex numbers, tuples, nested reports) and refuses
  anything else with a :class:`TypeError` naming the key path;
* the views (``_stability``, ``_regions``, ``_bounds``, ``_simulation``,
  ``_sweep``) list each report's fields, names and constant texts;
* :func:`view_of` (from ``_registry``) maps a report class to its view and
  imports the view module only when such a report is encoded; a caller that
  reads a few fields of a report (a sweep row) takes them from the same view.

:meth:`kfio._reporting.ReportPart.to_dict` is ``encode(self)``.
"""

from ._encode import encode, json_float, stamp
from ._registry import view_of

__all__ = ["encode", "json_float", "stamp", "view_of"]
