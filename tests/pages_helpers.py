"""Helpers of the page tests: a browser-like client signed in through the sign-in form, and the CSRF token read
from the page it was served (as a browser's form would send it)."""

from __future__ import annotations

import re

from litestar.testing import TestClient

from harness.processes import PASSWORD

_TOKEN = re.compile(r'name="csrf_token" value="([^"]+)"')


def csrf_from(html: str) -> str:
    match = _TOKEN.search(html)
    if match is None:
        raise AssertionError("the page has no CSRF token")
    return match.group(1)


def sign_in(client: TestClient, username: str, password: str = PASSWORD, next: str = "/patients") -> str:
    """Sign in through the form; returns the CSRF token of the first page after it."""
    form = client.get("/sign-in")
    r = client.post(
        "/sign-in",
        data={"csrf_token": csrf_from(form.text), "username": username, "password": password, "next": next},
        follow_redirects=True,
    )
    if r.status_code != 200 or "Sign out" not in r.text:
        raise AssertionError(f"sign-in failed: {r.status_code} {r.text[:300]}")
    return csrf_from(r.text)


def post_form(client: TestClient, url: str, data: dict, *, from_page: str | None = None, follow: bool = False):
    """POST a page form with the CSRF token of `from_page` (default: the form page `url` itself)."""
    token = csrf_from(client.get(from_page or url).text)
    return client.post(url, data={"csrf_token": token, **data}, follow_redirects=follow)
