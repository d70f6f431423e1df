"""/docs and /redoc work without internet: every script, style and icon the pages load is served
by the app itself."""

from __future__ import annotations

from html.parser import HTMLParser
from urllib.parse import urljoin, urlsplit

import pytest
from fastapi.testclient import TestClient

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
