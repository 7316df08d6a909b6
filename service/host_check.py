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

:class:`HostCheck` is Starlette's :class:`TrustedHostMiddleware` (its
normalised list, its ``*`` and its check that a wildcard is only ever
``*.domain``) with two rules of kfio's: the refusal is the 421 problem above,
not Starlette's plain-text 400, and the port is split off by
:func:`host_name`, which reads IPv6 literals in brackets the same way on every
Starlette release the dependency range allows.
"""

from __future__ import annotations

from collections.abc import Sequence

from starlette.middleware.trustedhost import TrustedHostMiddleware
from starlette.types import ASGIApp, Receive, Scope, Send

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


def trusted(name: str, hosts: Sequence[str]) -> bool:
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


class HostCheck(TrustedHostMiddleware):
    """ASGI middleware: 421 problem+json for a request whose ``Host`` is not trusted.

    A wildcard anywhere but a leading ``*.`` is refused when the app is built
    (``ValueError``): such a name could never match.
    """

    def __init__(self, app: ASGIApp, hosts: Sequence[str]) -> None:
        try:
            super().__init__(app, allowed_hosts=list(hosts), www_redirect=False)
        except AssertionError as exc:  # Starlette's pattern check
            raise ValueError(f"KFIO_TRUSTED_HOSTS: {exc}") from None
        self.hosts = tuple(self.allowed_hosts)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] in ("http", "websocket") and not self.allow_any:
            raw = next((v for k, v in scope.get("headers", ()) if k == b"host"), b"")
            name = host_name(raw.decode("latin-1"))
            if not trusted(name, self.allowed_hosts):
                detail = (
                    f"this server does not answer for the host name {name[:100]!r}; "
                    "its operator lists the names it answers for in KFIO_TRUSTED_HOSTS"
                )
                response = Problem(421, "misdirected-request", "Misdirected request", detail).response()
                await response(scope, receive, send)
                return
        await self.app(scope, receive, send)
