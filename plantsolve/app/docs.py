"""Swagger UI and ReDoc served from the package, so ``/docs`` and ``/redoc`` work on a closed plant
network: the pages' scripts, styles and icon come from the assets that ``fastapi-offline`` ships,
never from a CDN. The assets live under ``/docs/assets/``, so ``PROTECT_DOCS`` covers them too.

ReDoc's bundle shows Redocly's logo from their CDN in its side bar: the bundle is served from
``/docs/redoc.standalone.js`` with that address replaced by the service's own icon (a ``data:`` URL, so
no request at all). The same icon is ``/favicon.ico``, drawn once with numpy and written as PNG inside ICO
(no binary file to ship, no imaging library for the app).
"""

from __future__ import annotations

import base64
import struct
import zlib
from functools import cache
from pathlib import Path

import fastapi_offline
import numpy as np
from fastapi import FastAPI, Request
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html, get_swagger_ui_oauth2_redirect_html
from fastapi.responses import HTMLResponse, Response
from fastapi.staticfiles import StaticFiles

ASSETS_URL = "/docs/assets"
ASSETS_DIR = Path(fastapi_offline.__file__).parent / "static"
REDOC_JS = "redoc.standalone.js"
REDOC_CDN_LOGO = "https://cdn.redoc.ly/redoc/logo-mini.svg"
ICON_BLUE, ICON_WHITE = (31, 78, 121), (255, 255, 255)  # the dashboard's header blue, the pipe white


def _segment_distance(px: np.ndarray, py: np.ndarray, p0: tuple, p1: tuple) -> np.ndarray:
    dx, dy = p1[0] - p0[0], p1[1] - p0[1]
    t = np.clip(((px - p0[0]) * dx + (py - p0[1]) * dy) / (dx * dx + dy * dy), 0.0, 1.0)
    return np.hypot(px - p0[0] - t * dx, py - p0[1] - t * dy)


def icon_rgba(size: int) -> np.ndarray:
    """The service's icon as RGBA pixels: a pipe bend (a run down, an elbow, a run across) in white on a rounded
    blue square; drawn 4x finer and averaged down for smooth edges. Unit coordinates, y downwards."""
    fine = 4 * size
    c = (np.arange(fine) + 0.5) / fine
    x, y = np.meshgrid(c, c)
    corner = 1 / 6
    qx, qy = np.maximum(np.abs(x - 0.5) - (0.5 - corner), 0), np.maximum(np.abs(y - 0.5) - (0.5 - corner), 0)
    square = np.hypot(qx, qy) <= corner
    a, b, bend, half_width = 0.27, 0.73, 0.17, 0.075  # run down at x = a, across at y = b, elbow radius
    cx, cy = a + bend, b - bend
    elbow = np.where((x <= cx) & (y >= cy), np.abs(np.hypot(x - cx, y - cy) - bend), np.inf)
    distance = np.minimum.reduce([_segment_distance(x, y, (a, 0.14), (a, cy)), elbow,
                                  _segment_distance(x, y, (cx, b), (0.86, b))])
    pipe = (distance <= half_width) & square
    rgba = np.zeros((fine, fine, 4))
    rgba[..., :3] = np.where(pipe[..., None], ICON_WHITE, ICON_BLUE)
    rgba[..., 3] = np.where(square, 255, 0)
    return rgba.reshape(size, 4, size, 4, 4).mean(axis=(1, 3)).round().astype(np.uint8)


def _png(rgba: np.ndarray) -> bytes:
    """RGBA pixels as a PNG file (8 bits per channel, no filtering: an icon is a few hundred bytes either way)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    height, width = rgba.shape[:2]
    rows = b"".join(b"\x00" + rgba[r].tobytes() for r in range(height))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


@cache
def icon_png(size: int = 32) -> bytes:
    return _png(icon_rgba(size))


@cache
def favicon_ico(sizes: tuple[int, ...] = (16, 32, 48)) -> bytes:
    """An ICO file holding the icon as PNG images (what every browser reads)."""
    images = [icon_png(size) for size in sizes]
    offset = 6 + 16 * len(images)
    header = struct.pack("<HHH", 0, 1, len(images))
    for size, image in zip(sizes, images):
        header += struct.pack("<BBBBHHII", size % 256, size % 256, 0, 0, 1, 32, len(image), offset)
        offset += len(image)
    return header + b"".join(images)


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
