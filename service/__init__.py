"""kfio's shells around :mod:`kfio`: the ``kfio`` CLI and the HTTP service."""
