"""Swagger UI and ReDoc served from the package, so ``/docs`` and ``/redoc`` work on a closed plant
network: the pages' scripts, styles and icon come from the assets that ``fastapi-offline`` ships,
never from a CDN. The assets live under ``/docs/assets/``, so ``PROTECT_DOCS`` covers them too.

ReDoc's bundle shows Redocly's logo from their CDN in its side bar: the bundle is served from
``/docs/redoc.standalone.js`` with that address replaced by the service's own icon (a ``data:`` URL, so
no request at all). The same icon is ``/favicon.ico``, drawn once with Pillow (no binary file to ship).
"""

from __future__ import annotations

import base64
import io
from functools import cache
from pathlib import Path

import fastapi_offline
from fastapi import FastAPI, Request
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html, get_swagger_ui_oauth2_redirect_html
from fastapi.responses import HTMLResponse, Response
from fastapi.staticfiles import StaticFiles
from PIL import Image, ImageDraw  # Pillow comes with matplotlib: the icon is drawn, no binary file shipped

ASSETS_URL = "/docs/assets"
ASSETS_DIR = Path(fastapi_offline.__file__).parent / "static"
REDOC_JS = "redoc.standalone.js"
REDOC_CDN_LOGO = "https://cdn.redoc.ly/redoc/logo-mini.svg"
ICON_COLOURS = ("#1f4e79", "#ffffff")  # the dashboard's header blue, the pipe white


@cache
def icon_png(size: int = 32) -> bytes:
    """The service's icon: a pipe bend (two straight runs and an elbow) on a rounded blue square."""
    scale = 8  # drawn large and scaled down: smooth edges
    n = size * scale
    image = Image.new("RGBA", (n, n), (0, 0, 0, 0))
    draw = ImageDraw.Draw(image)
    background, pipe = ICON_COLOURS
    draw.rounded_rectangle((0, 0, n - 1, n - 1), radius=n // 6, fill=background)
    w = n // 7  # pipe width
    a, b = int(n * 0.22), int(n * 0.72)
    draw.line([(a, int(n * 0.12)), (a, b - n // 8)], fill=pipe, width=w)  # down
    draw.arc((a - w // 2, b - n // 4 - w // 2, a + n // 4 + w // 2, b + w // 2), 90, 180, fill=pipe, width=w)
    draw.line([(a + n // 8, b), (int(n * 0.88), b)], fill=pipe, width=w)  # across
    image = image.resize((size, size), Image.LANCZOS)
    out = io.BytesIO()
    image.save(out, format="PNG")
    return out.getvalue()


@cache
def favicon_ico() -> bytes:
    out = io.BytesIO()
    Image.open(io.BytesIO(icon_png(48))).save(out, format="ICO", sizes=[(16, 16), (32, 32), (48, 48)])
    return out.getvalue()


@cache
def redoc_bundle() -> bytes:
    """ReDoc's bundle with its one off-site address (the logo) replaced by the service's icon."""
    text = (ASSETS_DIR / REDOC_JS).read_text(encoding="utf-8")
    if REDOC_CDN_LOGO not in text:  # a new fastapi-offline: check what the bundle loads before serving it
        raise RuntimeError(f"{REDOC_JS} no longer holds {REDOC_CDN_LOGO}; check its external requests")
    icon = "data:image/png;base64," + base64.b64encode(icon_png()).decode()
    return text.replace(REDOC_CDN_LOGO, icon).encode("utf-8")


def install_favicon(app: FastAPI) -> None:
    """``/favicon.ico`` (browsers ask for it on every page; outside the protected paths, as they send no key)."""

    @app.get("/favicon.ico", include_in_schema=False)
    def favicon() -> Response:
        return Response(favicon_ico(), media_type="image/x-icon", headers={"Cache-Control": "public, max-age=86400"})


def install_docs(app: FastAPI, docs_url: str = "/docs", redoc_url: str = "/redoc") -> None:
    """The app must be built with ``docs_url=None, redoc_url=None`` (FastAPI's own pages load a CDN)."""
    app.mount(ASSETS_URL, StaticFiles(directory=ASSETS_DIR), name="docs-assets")
    install_favicon(app)

    @app.get(f"{docs_url}/{REDOC_JS}", include_in_schema=False)
    def redoc_js() -> Response:
        return Response(redoc_bundle(), media_type="text/javascript; charset=utf-8",
                        headers={"Cache-Control": "public, max-age=3600"})

    @app.get(docs_url, include_in_schema=False)
    async def swagger_ui(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        return get_swagger_ui_html(
            openapi_url=f"{root}{app.openapi_url}",
            title=f"{app.title} — API documentation",
            oauth2_redirect_url=f"{root}{docs_url}/oauth2-redirect",
            swagger_js_url=f"{root}{ASSETS_URL}/swagger-ui-bundle.js",
            swagger_css_url=f"{root}{ASSETS_URL}/swagger-ui.css",
            swagger_favicon_url=f"{root}{ASSETS_URL}/favicon.png",
            # no validator badge: Swagger UI would send the spec to a public validator
            swagger_ui_parameters={"validatorUrl": None, **(app.swagger_ui_parameters or {})},
        )

    @app.get(f"{docs_url}/oauth2-redirect", include_in_schema=False)
    async def swagger_ui_redirect() -> HTMLResponse:
        return get_swagger_ui_oauth2_redirect_html()

    @app.get(redoc_url, include_in_schema=False)
    async def redoc(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        return get_redoc_html(
            openapi_url=f"{root}{app.openapi_url}",
            title=f"{app.title} — API reference",
            redoc_js_url=f"{root}{docs_url}/{REDOC_JS}",
            redoc_favicon_url=f"{root}{ASSETS_URL}/favicon.png",
            with_google_fonts=False,
        )
