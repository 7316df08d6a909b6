"""Write (or check) ``openapi/openapi.json`` from the app.

Usage::

    python -m kfio.service.openapi_gen            # regenerate openapi/openapi.json
    python -m kfio.service.openapi_gen --check    # exit 1 if the checked-in file is stale
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Sequence

DEFAULT_PATH = Path("openapi") / "openapi.json"  # relative to the working directory: a repo checkout


def generate() -> str:
    """The OpenAPI document of :func:`kfio.service.app.create_app`, as stable text."""
    from .app import create_app
    from .settings import Settings

    document = create_app(Settings()).openapi()
    return json.dumps(document, indent=2, ensure_ascii=False) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m kfio.service.openapi_gen", description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=DEFAULT_PATH, help=f"file to write (default {DEFAULT_PATH})")
    parser.add_argument("--check", action="store_true", help="do not write; exit 1 if the file differs")
    args = parser.parse_args(argv)
    text = generate()
    if args.check:
        current = args.output.read_text(encoding="utf-8") if args.output.exists() else ""
        if current != text:
            print(f"{args.output} is stale; run: python -m kfio.service.openapi_gen", file=sys.stderr)
            return 1
        return 0
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(text, encoding="utf-8")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
