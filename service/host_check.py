"""Answer only for trusted host names: the defence against DNS rebinding.

A web page on another site can make the browser resolve its own host name to
127.0.0.1 and then send requests to a local kfio as if they were same-origin;
the ``Host`` header still carries the page's name.  :class:`HostCheck` answers
any request whose ``Host`` is not a trusted name with ``421 Misdirected
Request`` (problem+json, RFC 9110, section 15.5.20) before the app sees it.

Trusted names come from ``KFIO_TRUSTED_HOSTS``: a comma-separated list of host
names (without port; IPv6 addresses in brackets), ``*.example.org`` for every
subdomain of ``example.org``, or ``*`` for any name.  The default is the
loopback names ``localhost``, ``127.0.0.1`` and ``[::1]``.
"""

from __future__ import annotations

from typing import Any

from .problems import Problem
from .settings import LOOPBACK_HOSTS

__all__ = ["LOOPBACK_HOSTS", "HostCheck", "host_name", "parse_hosts", "trusted"]


def parse_hosts(text: str) -> tuple[str, ...]:
    """The trusted names of a ``KFIO_TRUSTED_HOSTS`` value, lower-cased, empty items dropped.

    Examples
    --------
    >>> parse_hosts(" LocalHost, [::1] ,,*.example.org")
    ('localhost', '[::1]', '*.example.org')
    """
    return tuple(h.strip().lower() for h in text.split(",") if h.strip())


def host_name(header: str) -> str:
    """The name of a ``Host`` header value, without its port, lower-cased.

    Examples
    --------
    >>> host_name("LOCALHOST:8000"), host_name("[::1]:8000"), host_name("[::1]"), host_name("127.0.0.1")
    ('localhost', '[::1]', '[::1]', '127.0.0.1')
    """
    header = header.strip().lower()
    if header.startswith("["):  # IPv6 literal: the port, if any, follows the bracket
        end = header.find("]")
        return header[: end + 1] if end >= 0 else header
    return header.rsplit(":", 1)[0] if header.count(":") == 1 else header


def trusted(name: str, hosts: tuple[str, ...]) -> bool:
    """Whether host ``name`` is one of ``hosts`` (``*`` trusts every name, ``*.d`` every subdomain of ``d``).

    Examples
    --------
    >>> trusted("api.example.org", ("*.example.org",)), trusted("example.org", ("*.example.org",))
    (True, False)
    >>> trusted("evil.example", ("localhost",)), trusted("", ("localhost",))
    (False, False)
    """
    if "*" in hosts:
        return True
    if not name:
        return False
    return any(name == h or (h.startswith("*.") and name.endswith(h[1:])) for h in hosts)


class HostCheck:
    """ASGI middleware: 421 problem+json for a request whose ``Host`` is not trusted."""

    def __init__(self, app: Any, hosts: tuple[str, ...]) -> None:
        self.app = app
        self.hosts = hosts

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] in ("http", "websocket") and "*" not in self.hosts:
            raw = next((v for k, v in scope.get("headers", ()) if k == b"host"), b"")
            name = host_name(raw.decode("latin-1"))
            if not trusted(name, self.hosts):
                detail = (
                    f"this server does not answer for the host name {name[:100]!r}; "
                    "its operator lists the names it answers for in KFIO_TRUSTED_HOSTS"
                )
                response = Problem(421, "misdirected-request", "Misdirected request", detail).response()
                await response(scope, receive, send)
                return
        await self.app(scope, receive, send)
