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
from burnedge.demo import (
    DEMO_ENCOUNTER_ID,
    DEMO_PATIENT_ID,
    DEMO_VISIT_IDS,
    FOREARM_WOUND_ID,
    SERIES_DAYS,
    SHIN_AREA_CM2,
    SHIN_WOUND_ID,
)
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


SHIN = "shin"
"""The second burn's folder inside the series' folder."""


def render_series(options: SeriesOptions) -> Path:
    """Render the forearm series and the shin's one visit, each in a process of its own (the renderer's native
    libraries stay out of the gateway); reused when already rendered with the same options."""
    spec = {"views": options.views, "width": options.width, "height": options.height, "seed": options.seed}
    size = ["--views", str(options.views), "--width", str(options.width), "--height", str(options.height)]
    _render(options.folder, spec, ["--series", *size, "--seed", str(options.seed), "--area-cm2", "18"])
    shin = ["--shape", "patch", *size, "--seed", str(options.seed + 1), "--area-cm2", f"{SHIN_AREA_CM2:g}"]
    _render(options.folder / SHIN, spec, shin + ["--depth-mm", "1.5"])
    return options.folder


def _render(folder: Path, spec: dict, arguments: list[str]) -> None:
    stamp = folder / "demo-spec.json"
    if stamp.exists() and json.loads(stamp.read_text()) == spec and (folder / "ground_truth.json").exists():
        return
    command = [sys.executable, "-m", "burnedge.cli", "phantom", "--out", str(folder), *arguments]
    if "--depth-mm" not in arguments:
        command += ["--depth-mm", "2.5"]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise GatewayError(f"rendering the demo phantoms failed: {done.stderr[-2000:]}")
    stamp.write_text(json.dumps(spec))


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


def analyse_series(
    client: GatewayClient, series: Path, options: SeriesOptions, bar: ProgressBar
) -> tuple[list[dict], dict]:
    """Upload each visit's photos of the forearm, and the shin's on the first visit, each for its own wound; ask for
    the analyses and follow them all. Returns the forearm's finished jobs and the shin's."""
    jobs = []
    visits = visit_arrivals(client)
    for day, (visit_id, arrival) in zip(SERIES_DAYS, visits, strict=True):
        name = f"day {day:>2}"
        session = series / f"session_day{day:02d}"
        jobs.append((name, _request(client, session, visit_id, arrival, FOREARM_WOUND_ID, options, bar, name)))
    visit_id, arrival = visits[0]
    jobs.append(("shin  ", _request(client, series / SHIN, visit_id, arrival, SHIN_WOUND_ID, options, bar, "shin  ")))
    finished = []
    for name, job in jobs:
        last = client.follow(job["id"], lambda e, n=name: bar.update(n, e))
        job = client.get(f"/api/v1/analyses/{job['id']}", "read the analysis")
        bar.done(name, last, job.get("history", []))
        finished.append(job)
    return finished[:-1], finished[-1]


def _request(
    client: GatewayClient,
    session: Path,
    visit_id: str,
    arrival: dt.datetime,
    wound_id: str,
    options: SeriesOptions,
    bar: ProgressBar,
    name: str,
) -> dict:
    """Upload one capture of one wound as a phone would, then ask for its analysis; returns the queued job."""
    photos = sorted((session / "images").glob("*.jpg"))
    assets = {}
    for i, photo in enumerate(photos, 1):
        # As a phone would: each photo says when it was taken (a few minutes after the arrival, on its day).
        taken = (arrival + dt.timedelta(minutes=10, seconds=20 * i)).astimezone()
        data = with_capture_time(photo.read_bytes(), taken)
        assets[photo.stem] = client.upload(photo, visit_id, data=data, wound_id=wound_id)["asset"]
        bar.line(f"{name}: uploaded {i}/{len(photos)} photos", final=i == len(photos))
    request: dict = {"wound_id": wound_id, "assets": [a["id"] for a in assets.values()]}
    if options.clinician_masks:
        request["masks"] = [
            {"asset_id": assets[m.stem]["id"], "png_base64": _b64(m)}
            for m in sorted((session / "masks").glob("*.png"))
            if m.stem in assets
        ]
    return client.post(f"/api/v1/encounters/{visit_id}/analyses", request, f"analyse {name.strip()}")


def healing_track(client: GatewayClient, wound_id: str, visits: int, timeout_s: float = 300.0) -> dict:
    """The wound's healing (its track and share of the body) once its track holds every measured visit (the worker
    updates it after each)."""
    deadline = time.monotonic() + timeout_s
    healing: dict = {}
    while time.monotonic() < deadline:
        healing = client.get(f"/api/v1/wounds/{wound_id}/healing", "read the healing track")
        if len((healing.get("track") or {}).get("sessions", [])) >= visits:
            return healing
        time.sleep(1)
    return healing


def _result(client: GatewayClient, job: dict) -> dict:
    try:
        return client.get(f"/api/v1/analyses/{job['id']}/result", "read the result")
    except GatewayError:
        return {"status": job["state"], "reason": job.get("error")}


def _b64(path: Path) -> str:
    import base64

    return base64.b64encode(path.read_bytes()).decode()


def run_demo(config: Config, options: SeriesOptions, password: str, *, keep_serving: bool) -> str:
    """Render, serve, upload, analyse, align; returns the summary (also printed before serving on)."""
    from burnedge.demo_progress import summary_table, wounds_lines
    from gateway.jobs.folders import analysis_dir, patient_dir

    bar = ProgressBar()
    bar.line(f"rendering the 4-visit phantom series into {options.folder} (reused on later runs) ...")
    series = render_series(options)
    gateway = ServedGateway(config).start()
    client = GatewayClient(gateway.url)
    try:
        bar.line(f"gateway with its analysis worker on {gateway.url}; acting as the clinic's phone")
        client.login("clinician", password)
        jobs, shin_job = analyse_series(client, series, options, bar)
        results = [_result(client, job) for job in jobs]
        measured = sum(r.get("status") == "ok" for r in results)
        healing = healing_track(client, FOREARM_WOUND_ID, measured) if measured else {}
        track = healing.get("track") or {}
        shin = _result(client, shin_job)
        shin_healing = healing_track(client, SHIN_WOUND_ID, 1) if shin.get("status") == "ok" else {}
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
                *wounds_lines(healing, shin, shin_healing),
                "",
                "Painted burn meshes (GLB; open in any glTF viewer) and every file of each analysis:",
                *files,
                f"Healing track: {patient_dir(config, DEMO_PATIENT_ID) / 'wounds' / FOREARM_WOUND_ID / 'track.json'}"
                f"  ({gateway.url}/api/v1/wounds/{FOREARM_WOUND_ID}/healing; both wounds:"
                f" {gateway.url}/api/v1/patients/{DEMO_PATIENT_ID}/healing)",
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
