"""The vendored browser libraries are the npm files the manifest names, and the pages load nothing from elsewhere."""

from __future__ import annotations

import hashlib
from html.parser import HTMLParser

from base.web.pages.assets import VENDOR_DIR, manifest

# Files in vendor/ that are ours, not a package's: the manifest itself, its README, and the licence texts of the
# libraries that model-viewer.min.js and tus.min.js bundle (gathered from those libraries' own tarballs).
NOT_IN_MANIFEST = {
    "MANIFEST.json",
    "README.md",
    "model-viewer/THIRD_PARTY_LICENSES.txt",
    "tus/THIRD_PARTY_LICENSES.txt",
}


class _Resources(HTMLParser):
    """The addresses a page's <script src> and <link href> load, and the text of any inline <script>."""

    def __init__(self) -> None:
        super().__init__()
        self.urls: list[str] = []
        self.inline_scripts: list[str] = []
        self._in_script = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        named = dict(attrs)
        if tag == "script":
            self._in_script = True
            if named.get("src"):
                self.urls.append(named["src"] or "")
        elif tag == "link" and named.get("href"):
            self.urls.append(named["href"] or "")

    def handle_endtag(self, tag: str) -> None:
        if tag == "script":
            self._in_script = False

    def handle_data(self, data: str) -> None:
        if self._in_script and data.strip():
            self.inline_scripts.append(data)


def _resources(html: str) -> _Resources:
    parser = _Resources()
    parser.feed(html)
    return parser


def test_every_manifest_entry_is_a_file_with_its_recorded_sha256():
    entries = manifest()
    assert {e.package for e in entries} == {
        "htmx.org",
        "htmx-ext-sse",
        "@google/model-viewer",
        "tus-js-client",
        "swagger-ui-dist",
        "js-aruco2",
    }
    for entry in entries:
        file = VENDOR_DIR / entry.path
        assert file.is_file(), entry.path
        assert hashlib.sha256(file.read_bytes()).hexdigest() == entry.sha256, entry.path
        assert entry.source.integrity.startswith("sha512-"), entry.path
        assert entry.licence, entry.path


def test_every_shipped_vendor_file_is_in_the_manifest():
    listed = {e.path for e in manifest()}
    shipped = {p.relative_to(VENDOR_DIR).as_posix() for p in VENDOR_DIR.rglob("*") if p.is_file()}
    assert shipped - NOT_IN_MANIFEST == listed


def test_each_vendored_package_folder_has_its_licence():
    folders = {p for p in VENDOR_DIR.iterdir() if p.is_dir()}
    assert len(folders) == 6
    for folder in folders:
        licence = next(
            name for name in ("LICENSE", "LICENSE.txt") if (folder / name).is_file()
        )  # as the package has it
        assert f"{folder.name}/{licence}" in {e.path for e in manifest()}


def test_a_vendored_script_is_served_without_logging_in(client):
    r = client.get("/static/vendor/htmx/htmx.min.js")
    assert r.status_code == 200
    assert "javascript" in r.headers["content-type"]
    assert hashlib.sha256(r.content).hexdigest() == next(e.sha256 for e in manifest() if e.path == "htmx/htmx.min.js")


def test_a_missing_static_file_is_404_and_no_path_escapes_the_folder(client):
    assert client.get("/static/vendor/htmx/nothing.js").status_code == 404
    assert client.get("/static/%2e%2e/pages/assets.py").status_code == 404
    assert client.get("/static/vendor/..%2f..%2fpages%2fassets.py").status_code == 404


def test_the_api_docs_load_only_local_files_and_no_inline_script(client):
    for path in ("/schema", "/schema/swagger"):
        r = client.get(path)
        assert r.status_code == 200, path
        assert r.headers["content-type"].startswith("text/html")
        page = _resources(r.text)
        assert page.inline_scripts == []
        assert page.urls, path
        for url in page.urls:
            assert url.startswith("/static/") or url == "data:,", url
        for url in page.urls:
            if url.startswith("/static/"):
                assert client.get(url).status_code == 200, url
        assert 'data-openapi-url="/schema/openapi.json"' in r.text


def test_the_openapi_document_is_still_served_and_the_cdn_renderers_are_gone(client):
    r = client.get("/schema/openapi.json")
    assert r.status_code == 200
    assert r.json()["info"]["title"] == "burnedge gateway"
    assert client.get("/schema/openapi.yaml").status_code == 200
    for cdn_page in ("/schema/redoc", "/schema/elements", "/schema/rapidoc"):
        assert client.get(cdn_page).status_code == 404, cdn_page


def test_the_phone_app_loads_only_local_files_and_no_inline_script(client):
    r = client.get("/app/")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    page = _resources(r.text)
    assert page.inline_scripts == [] and page.urls
    for url in page.urls:
        assert url.startswith(("/static/", "/app/")), url
        assert client.get(url).status_code == 200, url
