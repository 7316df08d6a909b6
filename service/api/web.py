"""The web page at ``/`` and the interactive docs at ``/docs`` and ``/redoc``, all served offline.

Every asset ships inside the Python package: the page (plain HTML, CSS and
JavaScript) and its example requests under ``kfio/service/static/``, and the
Swagger UI (Apache-2.0) and ReDoc (MIT) bundles from the ``fastapi-offline``
package (MIT).  Nothing is fetched from another host, so the page and the docs
work on a machine with no internet.  ReDoc's bundle would fetch its vendor's
logo from a CDN; ``/docs-assets/redoc.standalone.js`` is served with that
image's address emptied (:func:`offline_redoc`), so the logo is not drawn and
nothing is requested.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from fastapi import FastAPI
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html, get_swagger_ui_oauth2_redirect_html
from fastapi.responses import FileResponse, HTMLResponse, Response
from fastapi.staticfiles import StaticFiles

STATIC = Path(__file__).resolve().parent.parent / "static"
#: The one address ReDoc's bundle loads from another host: the vendor logo of its sidebar footer.
REDOC_LOGO = "https://cdn.redoc.ly/redoc/logo-mini.svg"


def _docs_assets() -> Path:
    import fastapi_offline

    return Path(fastapi_offline.__file__).resolve().parent / "static"


@lru_cache(maxsize=1)
def offline_redoc() -> bytes:
    """ReDoc's standalone bundle with the logo's address emptied: an ``<img src="">`` requests nothing.

    The image's ``onError`` hides it, so the sidebar footer shows only its text link.

    Raises
    ------
    RuntimeError
        The bundle no longer holds the logo's address (a new ``fastapi-offline``):
        look for what it loads instead before serving it.
    """
    bundle = (_docs_assets() / "redoc.standalone.js").read_bytes()
    if REDOC_LOGO.encode() not in bundle:
        raise RuntimeError(f"redoc.standalone.js no longer holds {REDOC_LOGO}: check what it loads from other hosts")
    return bundle.replace(REDOC_LOGO.encode(), b"")


def install(app: FastAPI) -> None:
    """Add ``/``, ``/docs``, ``/redoc`` and the static files to ``app`` (built with ``docs_url=None``)."""
    app.mount("/static", StaticFiles(directory=STATIC), name="static")

    @app.get("/docs-assets/redoc.standalone.js", include_in_schema=False)
    async def redoc_bundle() -> Response:  # registered before the mount below, so it shadows the vendor's file
        return Response(offline_redoc(), media_type="text/javascript")

    app.mount("/docs-assets", StaticFiles(directory=_docs_assets()), name="docs-assets")
    openapi_url = app.openapi_url or "/openapi.json"

    @app.api_route("/", methods=["GET", "HEAD"], include_in_schema=False)  # HEAD: link checkers, uptime probes
    async def index() -> FileResponse:
        return FileResponse(STATIC / "index.html", media_type="text/html")

    @app.get("/docs", include_in_schema=False)
    async def swagger_ui() -> HTMLResponse:
        return get_swagger_ui_html(
            openapi_url=openapi_url,
            title=f"{app.title} - API docs",
            swagger_js_url="/docs-assets/swagger-ui-bundle.js",
            swagger_css_url="/docs-assets/swagger-ui.css",
            swagger_favicon_url="/docs-assets/favicon.png",
            oauth2_redirect_url="/docs/oauth2-redirect",
            # the bundle's default validatorUrl is validator.swagger.io, whose badge image the standalone layout
            # draws for a page opened by host name; BaseLayout draws no badge, and null keeps it so
            swagger_ui_parameters={"validatorUrl": None},
        )

    @app.get("/docs/oauth2-redirect", include_in_schema=False)
    async def swagger_ui_redirect() -> HTMLResponse:
        return get_swagger_ui_oauth2_redirect_html()

    @app.get("/redoc", include_in_schema=False)
    async def redoc() -> HTMLResponse:
        return get_redoc_html(
            openapi_url=openapi_url,
            title=f"{app.title} - API reference",
            redoc_js_url="/docs-assets/redoc.standalone.js",
            redoc_favicon_url="/docs-assets/favicon.png",
            with_google_fonts=False,
        )
