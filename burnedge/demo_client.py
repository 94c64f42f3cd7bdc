"""A small HTTP client of the gateway, as a phone app would use it: log in, write records, upload pictures
with tus (resuming after a dropped connection), request an analysis and follow its progress as server-sent
events. The demo drives the real gateway with it over loopback."""

from __future__ import annotations

import base64
import json
import logging
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import httpx

from schemas.errors import BurnedgeError

log = logging.getLogger("burnedge.demo")
TUS = {"Tus-Resumable": "1.0.0"}
CHUNK = 1024 * 1024


class GatewayError(BurnedgeError):
    """The gateway answered with an error the demo cannot go on from; `http_status` is the HTTP status (0: none)."""

    def __init__(self, detail: str, http_status: int = 0):
        super().__init__(detail)
        self.http_status = http_status


class GatewayClient:
    def __init__(self, base_url: str = "", timeout_s: float = 60.0, *, http: httpx.Client | None = None):
        """Talks to `base_url`, or through `http` (any httpx client, such as Litestar's test client)."""
        self.http = http or httpx.Client(base_url=base_url, timeout=timeout_s)

    def close(self) -> None:
        self.http.close()

    def _check(self, r: httpx.Response, what: str) -> httpx.Response:
        if r.status_code >= 400:
            try:
                detail = r.json().get("detail", r.text)
            except ValueError:
                detail = r.text
            raise GatewayError(f"{what}: {r.status_code} {detail}", r.status_code)
        return r

    def login(self, username: str, password: str) -> None:
        r = self._check(
            self.http.post("/api/v1/auth/login", json={"username": username, "password": password}),
            f"log in as {username}",
        )
        self.http.headers["Authorization"] = f"Bearer {r.json()['access_token']}"

    def post(self, path: str, body: dict, what: str) -> dict:
        return self._check(self.http.post(path, json=body), what).json()

    def get(self, path: str, what: str) -> dict | list:
        return self._check(self.http.get(path), what).json()

    def get_bytes(self, path: str, what: str) -> bytes:
        return self._check(self.http.get(path), what).content

    def upload(
        self,
        path: Path,
        encounter_id: str,
        attempts: int = 5,
        data: bytes | None = None,
        wound_id: str | None = None,
    ) -> dict:
        """One photo over tus (`data` instead of the file's bytes when given), of the wound `wound_id` when given; a
        dropped connection resumes from the offset the gateway has. Returns the upload."""
        data = path.read_bytes() if data is None else data
        fields = {"encounter_id": encounter_id, "filename": path.name} | ({"wound_id": wound_id} if wound_id else {})
        meta = ",".join(f"{k} {base64.b64encode(v.encode()).decode()}" for k, v in fields.items())
        r = self._check(
            self.http.post(
                "/api/v1/uploads", headers={**TUS, "Upload-Length": str(len(data)), "Upload-Metadata": meta}
            ),
            f"upload {path.name}",
        )
        url = r.headers["location"]
        offset = 0
        for attempt in range(attempts):
            try:
                while offset < len(data):
                    piece = data[offset : offset + CHUNK]
                    r = self._check(
                        self.http.patch(
                            url,
                            content=piece,
                            headers={
                                **TUS,
                                "Upload-Offset": str(offset),
                                "Content-Type": "application/offset+octet-stream",
                            },
                        ),
                        f"upload {path.name}",
                    )
                    offset = int(r.headers["upload-offset"])
                return self.get(url, f"upload {path.name}")
            except httpx.TransportError as exc:
                log.warning("upload of %s interrupted (%s); resuming", path.name, exc)
                time.sleep(0.5 * (attempt + 1))
                offset = int(
                    self._check(self.http.head(url, headers=TUS), f"upload {path.name}").headers["upload-offset"]
                )
        raise GatewayError(f"upload of {path.name} kept failing after {attempts} tries")

    def follow(self, job_id: str, on_event: Callable[[dict], None]) -> dict:
        """Follow an analysis's server-sent events until it ends; returns the last event."""
        last: dict = {}
        while True:
            try:
                with self.http.stream(
                    "GET", f"/api/v1/analyses/{job_id}/events", timeout=httpx.Timeout(60, read=120)
                ) as r:
                    self._check(r, f"follow analysis {job_id}")
                    for kind, data in _events(r.iter_lines()):
                        last = json.loads(data)
                        on_event(last)
                        if kind == "end":
                            return last
            except httpx.TransportError as exc:  # the stream dropped: pick it up again
                log.warning("progress stream of %s dropped (%s); reconnecting", job_id, exc)
                time.sleep(1)


def _events(lines: Iterator[str]) -> Iterator[tuple[str, str]]:
    """(event type, data) of each server-sent event; comments (keep-alives) are skipped."""
    kind, data = "message", []
    for line in lines:
        if not line:
            if any(data):
                yield kind, "\n".join(data)
            kind, data = "message", []
        elif line.startswith(":"):
            continue
        else:
            field, _, value = line.partition(":")
            value = value[1:] if value.startswith(" ") else value
            if field == "event":
                kind = value
            elif field == "data":
                data.append(value)
