"""/docs and /redoc work without internet: every script, style and icon the pages load is served
by the app itself."""

from __future__ import annotations

import base64
import io
import re
from html.parser import HTMLParser
from urllib.parse import urljoin, urlsplit

import pytest
from fastapi.testclient import TestClient
from PIL import Image

from plantsolve.app.main import create_app
from tests.conftest import service_settings


class _Assets(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.urls: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        values = dict(attrs)
        if tag in ("script", "img") and values.get("src"):
            self.urls.append(values["src"])
        if tag == "link" and values.get("href"):
            self.urls.append(values["href"])


def _assets(html: str) -> list[str]:
    parser = _Assets()
    parser.feed(html)
    return parser.urls


@pytest.mark.parametrize(("page", "expected"), [("/docs", {"swagger-ui-bundle.js", "swagger-ui.css"}),
                                                 ("/redoc", {"redoc.standalone.js"})])
def test_documentation_pages_load_only_assets_the_app_serves(client, page, expected):
    response = client.get(page)
    assert response.status_code == 200 and response.headers["content-type"].startswith("text/html")
    urls = _assets(response.text)
    assert {url.rsplit("/", 1)[-1] for url in urls} >= expected
    for url in urls:
        parts = urlsplit(urljoin("http://testserver" + page, url))
        assert (parts.scheme, parts.netloc) == ("http", "testserver"), f"{page} loads {url} from another host"
        asset = client.get(parts.path)
        assert asset.status_code == 200 and len(asset.content) > 1000, url
    # nothing else in the page points off-host either (fonts, validators, spec URL)
    assert "https://" not in response.text and "http://" not in response.text
    spec_url = "/openapi.json"
    assert spec_url in response.text and client.get(spec_url).status_code == 200


def test_docs_assets_need_a_key_when_docs_are_protected(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, api_keys=["k"]))) as client:
        assert client.get("/docs/assets/swagger-ui.css").status_code == 401
        assert client.get("/docs/assets/swagger-ui.css", headers={"Authorization": "Bearer k"}).status_code == 200


def test_redoc_bundle_asks_no_cdn_for_its_logo(client):
    """ReDoc's side bar showed Redocly's logo from their CDN: the bundle the page loads has no off-site image,
    its logo is the service's icon inline."""
    page = client.get("/redoc").text
    js_url = next(u for u in _assets(page) if u.endswith("redoc.standalone.js"))
    bundle = client.get(js_url).text
    assert "cdn.redoc.ly" not in bundle
    assert not re.findall(r'src:"https?://', bundle), "an image the bundle loads from another host"
    logo = re.search(r'alt:"redocly logo",onError:[^,]+,src:"data:image/png;base64,([A-Za-z0-9+/=]+)"', bundle)
    assert logo and base64.b64decode(logo.group(1))[:8] == b"\x89PNG\r\n\x1a\n"


def test_favicon_is_served_from_the_package_without_a_key(tmp_path):
    with TestClient(create_app(service_settings(tmp_path, api_keys=["k"]))) as client:
        response = client.get("/favicon.ico")  # browsers send no key for it
        assert response.status_code == 200 and response.headers["content-type"] == "image/x-icon"
        icon = Image.open(io.BytesIO(response.content))
        assert icon.format == "ICO" and (32, 32) in icon.info["sizes"]
        pixels = icon.convert("RGB").getcolors(4096)
        assert len(pixels) > 2  # a drawn icon, not a blank square
