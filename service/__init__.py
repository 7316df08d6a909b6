"""kfio's shells around :mod:`analyzer`: the ``kfio`` CLI and the HTTP service."""
