"""The phone companion app at /app/: an installable, offline-first web app served by the gateway itself.

Its files live in gateway/phones/app/ (plain ES modules, no build step), or in `[gateway] phone_app_dir` where a
clinic serves a changed copy. The service worker is made here: it names
the app's version, a hash over every file it keeps, so a gateway with new app files gives phones a new service
worker, which takes over and tells the nurse; nothing queued on the phone is touched by an update (it lives in
IndexedDB, not in the worker's cache). Every file is revalidated by its ETag, so the phone fetches only what changed.
"""

from __future__ import annotations

import functools
import hashlib
import json
import mimetypes
from dataclasses import dataclass
from pathlib import Path

import msgspec
from litestar import Controller, Request, Response, get

from base.web.pages.assets import VENDOR_DIR
from base.web.pages.forms_spec import human
from gateway.dependencies import Services, ServicesDep
from processing.report.body_geometry import REGION_LABELS
from schemas.patient import EncounterMode, Sex
from schemas.record_parts import MechanismType
from schemas.wound import WoundSide

APP_DIR = Path(__file__).with_name("app")
APP_PATH = "/app"
VENDORED = {
    f"/static/vendor/{name}": VENDOR_DIR / name
    for name in ("tus/tus.min.js", "js-aruco2/cv.js", "js-aruco2/aruco.js", "js-aruco2/svd.js", "js-aruco2/posit1.js")
}
"""Files of the pages' vendored libraries the app uses, kept by its service worker too."""
TYPES = {".js": "text/javascript", ".webmanifest": "application/manifest+json", ".css": "text/css"}


@dataclass(frozen=True)
class AppFile:
    body: bytes
    media_type: str
    etag: str


@functools.cache
def app_files(app_dir: Path = APP_DIR) -> dict[str, AppFile]:
    """Every file of the app by its path under /app/ ("" is index.html), read once."""
    files = {}
    for path in sorted(p for p in app_dir.rglob("*") if p.is_file() and p.name != "sw.js"):
        name = path.relative_to(app_dir).as_posix()
        body = path.read_bytes()
        kind = TYPES.get(path.suffix) or mimetypes.guess_type(path.name)[0] or "application/octet-stream"
        files[name] = AppFile(body, kind, hashlib.sha256(body).hexdigest()[:32])
    files[""] = files["index.html"]
    body = msgspec.json.encode(choices())
    files["choices.json"] = AppFile(body, "application/json", hashlib.sha256(body).hexdigest()[:32])
    return files


def choices() -> dict[str, list[dict[str, str]]]:
    """The lists the app's forms offer, from the schemas the gateway checks them against."""
    return {
        "sexes": [{"value": s.value, "label": human(s.value)} for s in Sex],
        "modes": [{"value": m.value, "label": human(m.value)} for m in EncounterMode],
        "mechanisms": [{"value": m.value, "label": human(m.value)} for m in MechanismType],
        "sides": [{"value": s.value, "label": human(s.value)} for s in WoundSide],
        "regions": [{"value": r.value, "label": label} for r, label in REGION_LABELS.items()],
    }


def shell_paths(app_dir: Path = APP_DIR) -> list[str]:
    """Every address the service worker keeps: the app's own files, then the vendored scripts it loads."""
    return [f"{APP_PATH}/{name}" for name in app_files(app_dir) if name] + list(VENDORED)


@functools.cache
def service_worker(app_dir: Path = APP_DIR) -> AppFile:
    """sw.js with the app's version and the list of files it keeps."""
    shell = shell_paths(app_dir)
    digest = hashlib.sha256()
    for name, item in sorted(app_files(app_dir).items()):
        digest.update(f"{name}\0{item.etag}\0".encode())
    for path in VENDORED.values():
        digest.update(path.read_bytes())
    template = (app_dir / "sw.js").read_bytes()
    digest.update(template)
    version = digest.hexdigest()[:16]
    head = f"const VERSION = {json.dumps(version)};\nconst SHELL = {json.dumps([f'{APP_PATH}/', *shell])};\n"
    body = head.encode() + template
    return AppFile(body, "text/javascript", version)


def served_dir(services: Services) -> Path:
    """The folder the app is served from: the configured copy, or the one this version ships."""
    configured = services.config.gateway.phone_app_dir
    return Path(configured).resolve() if configured else APP_DIR


def _send(request: Request, item: AppFile) -> Response[bytes]:
    headers = {"ETag": f'"{item.etag}"', "Cache-Control": "no-cache"}
    if request.headers.get("if-none-match") == f'"{item.etag}"':
        return Response(b"", status_code=304, headers=headers)
    return Response(item.body, media_type=item.media_type, headers=headers)


class CompanionAppController(Controller):
    path = APP_PATH
    include_in_schema = False
    opt = {"exclude_from_auth": True}  # the app's own files: no patient data, and they must load offline first

    @get("/", sync_to_thread=False)
    def index(self, request: Request, services: ServicesDep) -> Response[bytes]:
        return _send(request, app_files(served_dir(services))[""])

    @get("/sw.js", sync_to_thread=False)
    def worker(self, request: Request, services: ServicesDep) -> Response[bytes]:
        response = _send(request, service_worker(served_dir(services)))
        response.headers["Service-Worker-Allowed"] = f"{APP_PATH}/"
        return response

    @get("/{name:path}", sync_to_thread=False)
    def file(self, request: Request, services: ServicesDep, name: str) -> Response[bytes]:
        item = app_files(served_dir(services)).get(name.lstrip("/"))
        if item is None:
            return Response(b"not part of the app", status_code=404, media_type="text/plain")
        return _send(request, item)
