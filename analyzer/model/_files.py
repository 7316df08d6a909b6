"""A user's file (or standard input) read whole, up to a size limit, refused with the field named.

The CLI's request files, trace files and the path given to :func:`kfio.sweep`
are read the same way: never more than one byte past the limit, so a huge
file or an endless pipe cannot fill memory.
"""

from __future__ import annotations

import os
import sys

from ..errors import InvalidInput


def read_limited(
    path: str | os.PathLike[str],
    max_bytes: int,
    field: str,
    too_large: str,
    *,
    name: str = "",
    stdin: bool = True,
) -> bytes:
    """The bytes of ``path`` (``-``: standard input, when ``stdin``), at most ``max_bytes`` of them.

    An unreadable file is ``InvalidInput(field, "cannot read <name>'<path>': <reason>")``; a longer one
    ``InvalidInput(field, too_large)``.

    Examples
    --------
    >>> read_limited("/no/such/file", 10, "TRACE", "too long")
    Traceback (most recent call last):
    ...
    kfio.errors.InvalidInput: TRACE: cannot read '/no/such/file': No such file or directory
    """
    try:
        if stdin and path == "-":
            data = sys.stdin.buffer.read(max_bytes + 1)
        else:
            with open(path, "rb") as fh:
                data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise InvalidInput(field, f"cannot read {name}{str(path)!r}: {exc.strerror}") from None
    if len(data) > max_bytes:
        raise InvalidInput(field, too_large)
    return data
