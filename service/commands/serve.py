"""``kfio serve [--host H] [--port P] [--workers N]``: the HTTP service (Uvicorn)."""

from __future__ import annotations

import argparse
import sys

from .. import exitcodes


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "serve",
        help="run the HTTP service",
        description="Serve the kfio HTTP API (docs at /docs). Every option also reads KFIO_<NAME> from the "
        "environment (KFIO_TIME_BUDGET_S, KFIO_MAX_QUEUE, ...); command-line options win.",
    )
    p.add_argument("--host", help="interface to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=int, help="TCP port (default 8000)")
    p.add_argument("--workers", type=int, help="analysis worker processes (default: CPU count, at most 4)")
    p.add_argument("--log-level", default="info", choices=["critical", "error", "warning", "info", "debug"])
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    import uvicorn
    from pydantic import ValidationError

    from ..app import create_app
    from ..settings import Settings

    overrides = {k: getattr(args, k) for k in ("host", "port", "workers") if getattr(args, k) is not None}
    try:
        settings = Settings(**overrides)
    except ValidationError as exc:
        err = exc.errors()[0]
        print(f"kfio: invalid setting {'.'.join(map(str, err['loc']))}: {err['msg']}", file=sys.stderr)
        return exitcodes.INVALID_INPUT
    # One server process: the analysis runs in the pool's worker processes, and
    # one process keeps one cache.
    uvicorn.run(
        create_app(settings),
        host=settings.host,
        port=settings.port,
        log_level=args.log_level,
        timeout_graceful_shutdown=5,
    )
    return exitcodes.STABLE
