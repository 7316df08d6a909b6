"""Who may use the service: optional bearer tokens (RFC 6750).

With tokens configured (``KFIO_API_TOKEN``, or ``KFIO_API_TOKEN_FILE`` with
one token per line, for several clients), :class:`BearerAuth` answers every
request but those for the page's shell, the docs and ``/healthz`` with ``401``
(problem+json, ``WWW-Authenticate: Bearer``) unless it carries
``Authorization: Bearer <token>`` for one of them.  The comparison is
:func:`hmac.compare_digest` against every token (its time does not depend on
where a guess first differs, nor on which token matched); tokens are never
logged, and never in a response.

Open without a token, because they hold nothing of anyone's and the page must
load to ask for the token: ``/healthz`` (liveness probes), ``/`` and
``/static/...`` (the page), ``/docs``, ``/redoc``, ``/docs-assets/...`` and
``/openapi.json`` (the contract, which ships with the package anyway).
Everything else needs the token: every ``/v1/...`` route, ``/readyz`` (its
counters describe the traffic), ``/schemas/...``, and unknown paths (401, not
404: an anonymous client learns nothing about the routes).

Secure by default where it matters (:func:`startup_tokens`): a server bound to
an address beyond this machine with no token configured generates one
(:func:`secrets.token_urlsafe`) and prints it at start, as Jupyter does,
unless ``KFIO_AUTH=none`` says the deployment controls access another way (a
reverse proxy that authenticates).  A loopback bind needs no token.
"""

from __future__ import annotations

import hmac
import ipaddress
import re
import secrets
from typing import TYPE_CHECKING, Any

from .problems import Problem

if TYPE_CHECKING:
    from .settings import Settings

#: Paths served without a token (exact), and the prefixes of the static trees served without one.
OPEN_PATHS = frozenset({"/healthz", "/", "/docs", "/docs/oauth2-redirect", "/redoc", "/openapi.json"})
OPEN_PREFIXES = ("/static/", "/docs-assets/")

#: A token's characters (RFC 6750's ``b64token``) and its least length: a short token can be guessed.
TOKEN_PATTERN = re.compile(r"[A-Za-z0-9\-._~+/]+=*")
MIN_TOKEN_CHARS = 16
#: Tokens a token file may hold at most (one per client).
MAX_TOKENS = 1000

SCHEME_NAME = "bearerAuth"


class SettingError(ValueError):
    """A setting of the deployment is unusable; ``setting`` names its variable (``KFIO_API_TOKEN_FILE``)."""

    def __init__(self, setting: str, rule: str) -> None:
        super().__init__(f"{setting}: {rule}")
        self.setting = setting
        self.rule = rule


def _check_token(token: str, setting: str, where: str = "") -> str:
    # the message never quotes the token: it may be a real one with a typo
    if len(token) < MIN_TOKEN_CHARS:
        raise SettingError(setting, f"a token{where} must have at least {MIN_TOKEN_CHARS} characters")
    if TOKEN_PATTERN.fullmatch(token) is None:
        raise SettingError(
            setting, f"a token{where} may hold only letters, digits and - . _ ~ + / (and = at its end), no spaces"
        )
    return token


def read_token_file(path: str) -> tuple[str, ...]:
    """The tokens of a token file: one per line; blank lines and lines starting with ``#`` are skipped.

    Raises
    ------
    SettingError
        The file cannot be read, holds no token, or a token is malformed (the
        line is named, never the token).
    """
    setting = "KFIO_API_TOKEN_FILE"
    try:
        with open(path, encoding="utf-8") as fh:
            text = fh.read(1 << 20)
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) else "not UTF-8 text"
        raise SettingError(setting, f"cannot read the token file {path!r}: {reason}") from None
    tokens = []
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.strip()
        if line and not line.startswith("#"):
            tokens.append(_check_token(line, setting, f" (line {number})"))
    if not tokens:
        raise SettingError(setting, f"the token file {path!r} holds no token (one per line)")
    if len(tokens) > MAX_TOKENS:
        raise SettingError(setting, f"at most {MAX_TOKENS} tokens")
    return tuple(tokens)


def configured_tokens(settings: Settings) -> tuple[str, ...]:
    """The tokens ``settings`` configure (``api_token`` and the lines of ``api_token_file``); empty: none.

    Raises
    ------
    SettingError
        A malformed token, an unreadable or empty token file, or tokens
        together with ``KFIO_AUTH=none``.
    """
    tokens: list[str] = []
    if settings.api_token is not None and settings.api_token.get_secret_value():  # empty: not set
        tokens.append(_check_token(settings.api_token.get_secret_value(), "KFIO_API_TOKEN"))
    if settings.api_token_file:
        tokens.extend(read_token_file(settings.api_token_file))
    if tokens and settings.auth == "none":
        raise SettingError("KFIO_AUTH", "'none' turns access control off, yet KFIO_API_TOKEN(_FILE) sets tokens")
    return tuple(dict.fromkeys(tokens))


def is_loopback(host: str) -> bool:
    """Whether binding ``host`` listens on this machine only: ``localhost`` or a loopback address.

    Any other name counts as reachable from elsewhere (``0.0.0.0``, ``::``, a
    host name): a token is then generated unless one is configured.

    Examples
    --------
    >>> [is_loopback(h) for h in ("127.0.0.1", "127.0.1.1", "::1", "[::1]", "localhost")]
    [True, True, True, True, True]
    >>> [is_loopback(h) for h in ("0.0.0.0", "::", "192.168.1.4", "example.org", "")]
    [False, False, False, False, False]
    """
    name = host.strip().lower()
    if name == "localhost":
        return True
    try:
        return ipaddress.ip_address(name.removeprefix("[").removesuffix("]")).is_loopback
    except ValueError:
        return False


def startup_tokens(settings: Settings) -> tuple[Settings, str | None]:
    """The settings a server starts with, and what it must print first (``None``: nothing).

    With tokens configured, or ``KFIO_AUTH=none``, or a loopback bind, the
    settings are kept.  Otherwise (an address beyond this machine and no
    token) a token is generated with :func:`secrets.token_urlsafe` for this run
    and returned in the message, to be printed at start.
    """
    from pydantic import SecretStr

    if configured_tokens(settings) or settings.auth == "none" or is_loopback(settings.host):
        return settings, None
    token = secrets.token_urlsafe(32)
    message = (
        f"kfio: the server listens on {settings.host}, beyond this machine, and no access token is configured;\n"
        "  every request but /healthz, the page and the docs needs this token, generated for this run:\n"
        f"    Authorization: Bearer {token}\n"
        "  (KFIO_API_TOKEN or KFIO_API_TOKEN_FILE choose tokens; KFIO_AUTH=none serves without any)"
    )
    return settings.model_copy(update={"api_token": SecretStr(token)}), message


def is_open(path: str) -> bool:
    """Whether ``path`` is served without a token (see the module's docstring).

    >>> [is_open(p) for p in ("/healthz", "/static/app.js", "/v1/analyze", "/readyz", "/healthz/x")]
    [True, True, False, False, False]
    """
    return path in OPEN_PATHS or path.startswith(OPEN_PREFIXES)


def _presented(scope: dict[str, Any]) -> bytes | None:
    """The token of the request's ``Authorization: Bearer`` header (scheme case-insensitive), if any."""
    raw: bytes | None = next((v for k, v in scope.get("headers", ()) if k == b"authorization"), None)
    if raw is None:
        return None
    scheme, _, token = raw.strip().partition(b" ")
    if scheme.lower() != b"bearer":
        return None
    return token.strip()


class BearerAuth:
    """ASGI middleware: 401 problem+json for a request to a closed path without a valid bearer token."""

    def __init__(self, app: Any, tokens: tuple[str, ...]) -> None:
        self.app = app
        self._tokens = tuple(t.encode("ascii") for t in tokens)

    def _valid(self, presented: bytes) -> bool:
        # every token is compared, whatever matched first
        return any([hmac.compare_digest(presented, t) for t in self._tokens])

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] not in ("http", "websocket") or is_open(scope.get("path", "")):
            await self.app(scope, receive, send)
            return
        presented = _presented(scope)
        if presented is not None and self._valid(presented):
            await self.app(scope, receive, send)
            return
        if presented is None:
            detail = (
                "this server needs an access token: send 'Authorization: Bearer <token>' (its operator sets the "
                "tokens with KFIO_API_TOKEN or KFIO_API_TOKEN_FILE, or kfio serve printed one at start)"
            )
            challenge = 'Bearer realm="kfio"'
        else:
            detail = "the bearer token is not one this server accepts"
            challenge = 'Bearer realm="kfio", error="invalid_token"'
        response = Problem(401, "unauthorized", "Access token required", detail).response()
        response.headers["WWW-Authenticate"] = challenge
        await response(scope, receive, send)


def declare_security(schema: dict[str, Any]) -> dict[str, Any]:
    """Add the bearer scheme to an OpenAPI document: optional per deployment, so "a token, or none".

    Every operation but ``/healthz`` lists the scheme and a 401 answer;
    ``/healthz`` declares no security.
    """
    components = schema.setdefault("components", {})
    components.setdefault("securitySchemes", {})[SCHEME_NAME] = {
        "type": "http",
        "scheme": "bearer",
        "description": "Needed when the deployment sets tokens (KFIO_API_TOKEN, KFIO_API_TOKEN_FILE) or serves "
        "beyond loopback with a generated one; every route but /healthz then answers 401 without it.",
    }
    unauthorized = {
        "description": "The deployment needs a bearer token and the request carried none, or a wrong one",
        "content": {"application/problem+json": {"schema": {"$ref": "#/components/schemas/Problem"}}},
    }
    for path, item in schema.get("paths", {}).items():
        for operation in item.values():
            if not isinstance(operation, dict) or "responses" not in operation:
                continue
            if is_open(path):
                operation["security"] = []
            else:
                operation["security"] = [{SCHEME_NAME: []}, {}]
                operation["responses"] = dict(sorted({**operation["responses"], "401": unauthorized}.items()))
    return schema
