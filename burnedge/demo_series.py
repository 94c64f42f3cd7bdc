"""The one-command demo's healing series: four visits of a rendered burn, through the real gateway and queue.

It renders a 4-visit phantom series (days 0, 7, 14, 21: the burn shrinks and heals, the limb is moved
between visits), starts the gateway with its worker on loopback, and then acts as the clinic's phone: it
records a patient and the four visits, uploads every photo with tus, asks for the four analyses, follows
their progress as server-sent events, and reads back the healing track.
"""

from __future__ import annotations

import datetime as dt
import json
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import httpx
import uvicorn

from base.storage.durable import replace_atomically
from burnedge.demo import DEMO_ENCOUNTER_ID, DEMO_PATIENT_ID, DEMO_VISIT_IDS, SERIES_DAYS
from burnedge.demo_client import GatewayClient, GatewayError
from burnedge.demo_progress import ProgressBar
from gateway.app import create_app
from gateway.server import SHUTDOWN_GRACE_S
from processing.capture.stamp import with_capture_time
from schemas.config import Config


@dataclass(frozen=True)
class SeriesOptions:
    folder: Path
    """Where the rendered phantom series is kept (reused when already rendered with the same options)."""
    views: int = 8
    width: int = 1280
    height: int = 960
    seed: int = 7
    clinician_masks: bool = False
    """Send the phantom's exact burn masks as a clinician's masks (otherwise the model finds the burn)."""


def render_series(options: SeriesOptions) -> Path:
    """Render the series in a process of its own (the renderer's native libraries stay out of the gateway)."""
    spec = {"views": options.views, "width": options.width, "height": options.height, "seed": options.seed}
    stamp = options.folder / "demo-spec.json"
    if stamp.exists() and json.loads(stamp.read_text()) == spec and (options.folder / "ground_truth.json").exists():
        return options.folder
    command = [
        sys.executable,
        "-m",
        "burnedge.cli",
        "phantom",
        "--series",
        "--out",
        str(options.folder),
        "--views",
        str(options.views),
        "--width",
        str(options.width),
        "--height",
        str(options.height),
        "--seed",
        str(options.seed),
        "--area-cm2",
        "18",
        "--depth-mm",
        "2.5",
    ]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise GatewayError(f"rendering the demo phantoms failed: {done.stderr[-2000:]}")
    stamp.write_text(json.dumps(spec))
    return options.folder


class ServedGateway:
    """The gateway (and its analysis worker) served from a thread of this process, on loopback."""

    def __init__(self, config: Config):
        self.config = config
        self.server = uvicorn.Server(
            uvicorn.Config(
                create_app(config, start_workers=True),
                host=config.gateway.host,
                port=config.gateway.port,
                log_level="warning",
                access_log=False,
                timeout_graceful_shutdown=SHUTDOWN_GRACE_S,
            )
        )
        self.thread = threading.Thread(target=self.server.run, name="gateway", daemon=True)

    @property
    def url(self) -> str:
        return f"http://{self.config.gateway.host}:{self.config.gateway.port}"

    def start(self, timeout_s: float = 60.0) -> ServedGateway:
        self.thread.start()
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if not self.thread.is_alive():
                raise GatewayError(f"the gateway did not start on {self.url} (is the port in use? try --port)")
            try:
                if httpx.get(self.url + "/health", timeout=1).status_code == 200:
                    return self
            except httpx.HTTPError:
                time.sleep(0.2)
        raise GatewayError(f"the gateway did not answer on {self.url} within {timeout_s:.0f} s")

    def wait(self) -> None:
        while self.thread.is_alive():
            self.thread.join(timeout=1)

    def stop(self) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=30)


def visit_arrivals(client: GatewayClient) -> list[tuple[str, dt.datetime]]:
    """The demo patient's four visits (recorded by the demo's seeding) and when each began, read as the phone
    reads them."""
    visits = []
    for visit_id in DEMO_VISIT_IDS:
        encounter = client.get(f"/api/v1/encounters/{visit_id}", "read the visit")
        visits.append((visit_id, dt.datetime.fromisoformat(encounter["data"]["time_of_arrival"])))
    return visits


def analyse_series(client: GatewayClient, series: Path, options: SeriesOptions, bar: ProgressBar) -> list[dict]:
    """Upload each visit's photos, ask for its analysis, follow them all; returns the finished jobs."""
    jobs = []
    for day, (visit_id, arrival) in zip(SERIES_DAYS, visit_arrivals(client), strict=True):
        session = series / f"session_day{day:02d}"
        photos = sorted((session / "images").glob("*.jpg"))
        assets = {}
        for i, photo in enumerate(photos, 1):
            # As a phone would: each photo says when it was taken (a few minutes after the arrival, on its day).
            taken = (arrival + dt.timedelta(minutes=10, seconds=20 * i)).astimezone()
            upload = client.upload(photo, visit_id, data=with_capture_time(photo.read_bytes(), taken))
            assets[photo.stem] = upload["asset"]
            bar.line(f"day {day:>2}: uploaded {i}/{len(photos)} photos", final=i == len(photos))
        request: dict = {"assets": [a["id"] for a in assets.values()]}
        if options.clinician_masks:
            request["masks"] = [
                {"asset_id": assets[m.stem]["id"], "png_base64": _b64(m)}
                for m in sorted((session / "masks").glob("*.png"))
                if m.stem in assets
            ]
        jobs.append((day, client.post(f"/api/v1/encounters/{visit_id}/analyses", request, f"analyse day {day}")))
    finished = []
    for day, job in jobs:
        last = client.follow(job["id"], lambda e, d=day: bar.update(f"day {d:>2}", e))
        job = client.get(f"/api/v1/analyses/{job['id']}", "read the analysis")
        bar.done(f"day {day:>2}", last, job.get("history", []))
        finished.append(job)
    return finished


def healing_track(client: GatewayClient, visits: int, timeout_s: float = 300.0) -> dict:
    """The patient's healing track once it holds every measured visit (the worker updates it after each)."""
    deadline = time.monotonic() + timeout_s
    track: dict = {}
    while time.monotonic() < deadline:
        try:
            track = client.get(f"/api/v1/patients/{DEMO_PATIENT_ID}/healing", "read the healing track")
            if len(track.get("sessions", [])) >= visits:
                return track
        except GatewayError as exc:
            if exc.http_status != 404:
                raise
        time.sleep(1)
    return track


def _b64(path: Path) -> str:
    import base64

    return base64.b64encode(path.read_bytes()).decode()


def run_demo(config: Config, options: SeriesOptions, password: str, *, keep_serving: bool) -> str:
    """Render, serve, upload, analyse, align; returns the summary (also printed before serving on)."""
    from burnedge.demo_progress import summary_table
    from gateway.jobs.folders import analysis_dir, patient_dir

    bar = ProgressBar()
    bar.line(f"rendering the 4-visit phantom series into {options.folder} (reused on later runs) ...")
    series = render_series(options)
    gateway = ServedGateway(config).start()
    client = GatewayClient(gateway.url)
    try:
        bar.line(f"gateway with its analysis worker on {gateway.url}; acting as the clinic's phone")
        client.login("clinician", password)
        jobs = analyse_series(client, series, options, bar)
        results = []
        for job in jobs:
            try:
                results.append(client.get(f"/api/v1/analyses/{job['id']}/result", "read the result"))
            except GatewayError:
                results.append({"status": job["state"], "reason": job.get("error")})
        measured = sum(r.get("status") == "ok" for r in results)
        track = healing_track(client, measured) if measured else {}
        files = [
            f"  day {day:>2}: {analysis_dir(config, job['id']) / 'surface' / 'burn_surface.glb'}"
            f"  ({gateway.url}/api/v1/analyses/{job['id']}/artifacts)"
            for day, job in zip(SERIES_DAYS, jobs, strict=True)
        ]
        report = Path(config.gateway.database).resolve().parent / "burnedge-demo-report.pdf"
        pdf = client.get_bytes(f"/api/v1/encounters/{DEMO_ENCOUNTER_ID}/report.pdf", "make the clinical report")
        replace_atomically(report, pdf)
        text = "\n".join(
            [
                "",
                "Healing series: patient Tomas Demo, four visits of a rendered forearm burn (model: "
                + ("the phantom's exact masks sent as a clinician's" if options.clinician_masks else "burnedge's U-Net")
                + ")",
                "",
                summary_table(track, jobs, results),
                "",
                "Painted burn meshes (GLB; open in any glTF viewer) and every file of each analysis:",
                *files,
                f"Healing track: {patient_dir(config, DEMO_PATIENT_ID) / 'track.json'}"
                f"  ({gateway.url}/api/v1/patients/{DEMO_PATIENT_ID}/healing)",
                f"The analyses' log (COLMAP and the workers): {config.jobs.log_file or 'the output above'}",
                f"The clinical report of the day-0 visit (all four visits, decision support): {report}"
                f"  ({gateway.url}/api/v1/encounters/{DEMO_ENCOUNTER_ID}/report.pdf)",
                "Decision support only: a clinician confirms every figure. Surface relief is geometry, not burn depth.",
                "",
                f"Open the patient's page in a browser (sign in as clinician, password {password}):",
                f"  {gateway.url}/patients/{DEMO_PATIENT_ID}",
            ]
        )
        print(text, flush=True)
        if keep_serving:
            print(f"\nThe gateway keeps running on {gateway.url} (API docs at /schema); Ctrl-C stops it.", flush=True)
            gateway.wait()
        return text
    finally:
        client.close()
        gateway.stop()
