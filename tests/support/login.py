"""Logging a test client in to the dashboard as a browser does: the login page (its CSRF token and cookie),
then the form."""

from __future__ import annotations

import re

CSRF = re.compile(r'name="csrf" value="([A-Za-z0-9_-]+)"')


def login_csrf(client) -> str:
    """Open the login page; the CSRF token of its form (the client now holds the matching cookie)."""
    page = client.get("/dashboard/login")
    assert page.status_code == 200, page.text
    return CSRF.search(page.text).group(1)


def log_in(client, key: str, **kwargs):
    """Post the login form with ``key``; the response (a 303 to the dashboard when the key is valid)."""
    return client.post("/dashboard/login", data={"key": key, "csrf": login_csrf(client)}, **kwargs)
