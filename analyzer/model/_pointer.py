"""JSON pointers (RFC 6901) of the fields that errors name.

Every error of kfio names the offending value by a JSON pointer into the
request (``InvalidInput.field``, the problem document's ``field``).  Object
keys are user text (sensor names, history keys), so each reference token is
escaped as RFC 6901, section 3, requires: ``~`` as ``~0`` and ``/`` as ``~1``;
:func:`pointer_tokens` undoes it (``~1`` first, then ``~0``, section 4).
The whole request is written ``/``, as kfio's errors always have (RFC 6901
writes it as the empty string, and ``/`` as the key ``""`` of the top level;
a request's top level has only the keys ``system``, ``channel`` and
``options``, so the two never meet).
"""

from __future__ import annotations

from collections.abc import Iterable


def json_pointer(parts: Iterable[str | int]) -> str:
    """The JSON pointer of the path ``parts`` (object keys and array indices), escaped per RFC 6901.

    Examples
    --------
    >>> json_pointer(["channel", "channels", "a/b~c", "arrival_probability"])
    '/channel/channels/a~1b~0c/arrival_probability'
    >>> json_pointer(["system", "A", 0, 1])
    '/system/A/0/1'
    >>> json_pointer([])
    '/'
    """
    tokens = [str(p).replace("~", "~0").replace("/", "~1") for p in parts]
    return "/" + "/".join(tokens) if tokens else "/"


def pointer_tokens(pointer: str) -> list[str]:
    """The unescaped reference tokens of ``pointer`` (the inverse of :func:`json_pointer`).

    Examples
    --------
    >>> pointer_tokens("/channel/channels/a~1b~0c")
    ['channel', 'channels', 'a/b~c']
    >>> pointer_tokens(json_pointer(["~1", "/"]))
    ['~1', '/']
    """
    if pointer in ("", "/"):
        return []
    return [t.replace("~1", "/").replace("~0", "~") for t in pointer[1:].split("/")]
