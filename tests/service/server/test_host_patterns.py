"""The host check is Starlette's TrustedHostMiddleware with kfio's refusal and port rules."""

from __future__ import annotations

import pytest
from starlette.middleware.trustedhost import TrustedHostMiddleware

from kfio.service.host_check import HostCheck


async def _app(scope, receive, send) -> None:  # pragma: no cover - never called here
    raise AssertionError


def test_the_check_is_starlettes_middleware_with_its_normalised_names() -> None:
    check = HostCheck(_app, ("LocalHost", "*.Example.org"))
    assert isinstance(check, TrustedHostMiddleware)
    assert check.allowed_hosts == ["localhost", "*.example.org"] and not check.allow_any
    assert HostCheck(_app, ("localhost", "*")).allow_any


@pytest.mark.parametrize("pattern", ["api.*.example.org", "*example.org", "local*"])
def test_a_wildcard_that_could_never_match_is_refused_at_start(pattern: str) -> None:
    with pytest.raises(ValueError, match="KFIO_TRUSTED_HOSTS"):
        HostCheck(_app, ("localhost", pattern))
