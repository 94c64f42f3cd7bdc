"""A real Orthanc PACS for tests, from Debian's packages (`orthanc`, `orthanc-dicomweb`): a temporary configuration
and storage folder, the DICOMweb plugin, HTTP on a free loopback port with basic authentication, and no DICOM
listener. Started and stopped by the tests, as PostgreSQL is (harness/postgres.py)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import httpx

from harness.processes import free_port

PLUGIN_FOLDERS = ("/usr/share/orthanc/plugins", "/usr/lib/orthanc")
USER, PASSWORD = "burnedge", "pacs-test-password"


class OrthancMissing(RuntimeError):
    """Orthanc or its DICOMweb plugin is not installed (deploy/bootstrap.sh installs both)."""


def binaries() -> tuple[Path, Path]:
    """Orthanc's program and the DICOMweb plugin: $BURNEDGE_TEST_ORTHANC and $BURNEDGE_TEST_ORTHANC_DICOMWEB, else
    where Debian puts them."""
    program = os.environ.get("BURNEDGE_TEST_ORTHANC") or shutil.which("Orthanc") or "/usr/sbin/Orthanc"
    plugin = os.environ.get("BURNEDGE_TEST_ORTHANC_DICOMWEB", "")
    candidates = [Path(plugin)] if plugin else [Path(f) / "libOrthancDicomWeb.so" for f in PLUGIN_FOLDERS]
    found = next((p for p in candidates if p.is_file()), None)
    if not Path(program).is_file() or found is None:
        raise OrthancMissing(
            "Orthanc with its DICOMweb plugin is not installed (apt-get install orthanc orthanc-dicomweb, or set "
            "BURNEDGE_TEST_ORTHANC and BURNEDGE_TEST_ORTHANC_DICOMWEB)"
        )
    return Path(program), found


class OrthancServer:
    """One throwaway Orthanc; start() it, stop() it; its DICOMweb root is `dicomweb_url`."""

    def __init__(self) -> None:
        self.program, self.plugin = binaries()
        self.folder = Path(tempfile.mkdtemp(prefix="burnedge-orthanc-"))
        self.port = free_port()
        self.process: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def dicomweb_url(self) -> str:
        return f"{self.url}/dicom-web"

    def client(self) -> httpx.Client:
        """Orthanc's own REST API, signed in."""
        return httpx.Client(base_url=self.url, auth=(USER, PASSWORD), timeout=30)

    def _config(self) -> dict:
        return {
            "Name": "burnedge-test-pacs",
            "StorageDirectory": str(self.folder / "storage"),
            "IndexDirectory": str(self.folder / "index"),
            "HttpPort": self.port,
            "RemoteAccessAllowed": False,
            "AuthenticationEnabled": True,
            "RegisteredUsers": {USER: PASSWORD},
            "DicomServerEnabled": False,
            "Plugins": [str(self.plugin)],
            "DicomWeb": {"Enable": True, "Root": "/dicom-web/"},
            "OverwriteInstances": True,
            "StorageCompression": False,
        }

    def start(self, timeout_s: float = 60) -> OrthancServer:
        config = self.folder / "orthanc.json"
        config.write_text(json.dumps(self._config(), indent=2))
        log = (self.folder / "orthanc.log").open("wb")
        self.process = subprocess.Popen([str(self.program), str(config)], stdout=log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"Orthanc stopped at start: {self.log_tail()}")
            try:
                with self.client() as http:
                    if http.get("/system").status_code == 200:
                        return self
            except httpx.TransportError:
                pass
            time.sleep(0.2)
        self.stop()
        raise RuntimeError(f"Orthanc did not answer within {timeout_s:.0f} s: {self.log_tail()}")

    def log_tail(self) -> str:
        path = self.folder / "orthanc.log"
        return path.read_text(errors="replace")[-2000:] if path.exists() else ""

    def halt(self) -> None:
        """Stop the process, keeping its folder (a test of an unreachable PACS)."""
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=10)

    def stop(self) -> None:
        try:
            self.halt()
        finally:
            shutil.rmtree(self.folder, ignore_errors=True)
