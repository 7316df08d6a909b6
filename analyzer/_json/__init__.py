"""kfio's JSON contract, in one place: one encoder and one view per report class.

* :func:`encode` holds every mechanical rule (finite floats or ``null``, NumPy
  arrays and scalars, complex numbers, tuples, nested reports) and refuses
  anything else with a :class:`TypeError` naming the key path;
* the views (``_stability``, ``_regions``, ``_bounds``, ``_simulation``,
  ``_sweep``) list each report's fields, names and constant texts;
* :mod:`kfio._json._registry` maps a report class to its view and imports the
  view module only when such a report is encoded.

:meth:`kfio._reporting.ReportPart.to_dict` is ``encode(self)``.
"""

from ._encode import encode, json_float, stamp

__all__ = ["encode", "json_float", "stamp"]
