"""Analyses through the real gateway process and its worker: progress as server-sent events, results in the
patient's record, cancel, and SIGKILL of a worker or of the whole gateway in the middle of a reconstruction."""

from __future__ import annotations

import base64
import datetime as dt
import os
import signal
import time
from pathlib import Path

import pytest

from burnedge.demo_client import GatewayClient
from harness.bodies import encounter_body, patient_body
from harness.processes import GatewayProcess, add_user_cli, free_port, login
from processing.capture.stamp import with_capture_time
from tests.phantom_helpers import SMALL, render_small_patch

FAST_QUEUE = {
    "BURNEDGE_JOBS_LEASE_S": "3",
    "BURNEDGE_JOBS_NICE": "0",
    "BURNEDGE_JOBS_HEARTBEAT_S": "0.5",
    "BURNEDGE_JOBS_POLL_S": "0.3",
    "BURNEDGE_JOBS_REAP_EVERY_S": "1",
    "BURNEDGE_JOBS_RETRY_BASE_S": "0",
}


def children(pid: int) -> list[int]:
    """Direct child processes of `pid` started by multiprocessing (workers, analyses), from /proc."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
                cmdline = (entry / "cmdline").read_bytes()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid and b"spawn_main" in cmdline:
                found.append(int(entry.name))
    return found


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def wait_for(predicate, timeout_s: float, what: str, seen=None):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError(f"timed out after {timeout_s:.0f} s waiting for {what}" + (f"; last {seen()}" if seen else ""))


def at_stage(phone: GatewayClient, job_id: str, stage: str, timeout_s: float = 180) -> None:
    wait_for(lambda: job(phone, job_id)["stage"] == stage, timeout_s, f"stage {stage}", lambda: job(phone, job_id))


@pytest.fixture(scope="module")
def phantom(tmp_path_factory) -> Path:
    return render_small_patch(tmp_path_factory.mktemp("phantom"))


@pytest.fixture(scope="module")
def gateway(tmp_path_factory):
    folder = tmp_path_factory.mktemp("gateway")
    process = GatewayProcess(folder / "gw.sqlite3", free_port())
    process.env = dict(FAST_QUEUE)
    add_user_cli(process.db, "dr.jobs", "clinician")
    process.start()
    yield process
    process.stop()


@pytest.fixture(scope="module")
def phone(gateway) -> GatewayClient:
    client = GatewayClient(gateway.url)
    client.http.headers.update(login(client.http, "dr.jobs"))
    yield client
    client.close()


def new_visit(
    phone: GatewayClient,
    phantom: Path,
    *,
    mode: str = "emergency",
    injury_hours_ago: float = 3,
    taken_hours_after_injury: float | None = None,
) -> tuple[str, dict[str, str]]:
    """A patient and a visit with the phantom's photos uploaded (stamped by their camera when `taken_...`)."""
    p = patient_body()
    phone.post("/api/v1/patients", p, "patient")
    e = encounter_body(p["id"], mode=mode, injury_hours_ago=injury_hours_ago)
    phone.post("/api/v1/encounters", e, "encounter")
    assets = {}
    for f in sorted((phantom / "images").glob("*.jpg")):
        data = f.read_bytes()
        if taken_hours_after_injury is not None:
            taken = dt.datetime.fromisoformat(e["time_of_injury"]) + dt.timedelta(hours=taken_hours_after_injury)
            data = with_capture_time(data, taken.astimezone(dt.timezone(dt.timedelta(hours=3))))
        assets[f.stem] = phone.upload(f, e["id"], data=data)["asset"]["id"]
    return e["id"], assets


def true_masks(phantom: Path, assets: dict[str, str]) -> dict:
    return {
        "masks": [
            {"asset_id": assets[m.stem], "png_base64": base64.b64encode(m.read_bytes()).decode()}
            for m in sorted((phantom / "masks").glob("*.png"))
        ]
    }


def job(phone: GatewayClient, job_id: str) -> dict:
    return phone.get(f"/api/v1/analyses/{job_id}", "read the analysis")


@pytest.fixture(scope="module")
def uninterrupted(phone, phantom) -> tuple[dict, list[dict], dict]:
    """One analysis followed from request to result over server-sent events: (job, events, result). The photos were
    taken 3 h after the injury and are analysed 20 days later."""
    enc, assets = new_visit(phone, phantom, injury_hours_ago=20 * 24 + 3, taken_hours_after_injury=3)
    requested = phone.post(f"/api/v1/encounters/{enc}/analyses", true_masks(phantom, assets), "request")
    events: list[dict] = []
    last = phone.follow(requested["id"], events.append)
    assert last["state"] == "done", last
    return job(phone, requested["id"]), events, phone.get(f"/api/v1/analyses/{requested['id']}/result", "result")


def test_progress_arrives_as_server_sent_events_and_the_result_is_stored(uninterrupted, phone, phantom):
    finished, events, result = uninterrupted
    stages = [e["stage"] for e in events if e["state"] == "running"]
    for stage in ("sfm", "dense", "mesh", "metrics"):  # the quick ones may pass between two polls
        assert stage in stages, stages
    fractions = [e["fraction"] for e in events]
    assert fractions == sorted(fractions) and events[-1]["fraction"] == 1.0 and events[-1]["result_status"] == "ok"
    assert finished["state"] == "done" and finished["attempts"] == 1 and finished["error"] is None
    assert result["status"] == "ok" and result["confidence"]["clinician_masks"] == SMALL["views"]
    truth = __import__("json").loads((phantom / "ground_truth.json").read_text())
    assert result["metrics"]["area_cm2"] == pytest.approx(truth["burn_area_cm2"], rel=0.04)
    # The photos' camera clock says 3 h after the injury: provisional, though analysed 20 days later.
    assert result["provisional"] is True and result["hours_since_injury"] == pytest.approx(3.0, abs=0.01)
    assert (
        finished["captured"]["source"] == "camera"
        and finished["captured"]["detail"] == f"camera clock of {SMALL['views']} of {SMALL['views']} pictures"
    )
    assert finished["history"] == []
    [attempt] = phone.get(f"/api/v1/analyses/{finished['id']}/attempts", "attempts")
    assert attempt["outcome"] == "done" and attempt["attempt"] == 1 and attempt["resumed_from"] == ""
    assert result["metrics"]["tbsa_percent"] > 0  # height and weight came from the patient's record


def test_the_result_is_in_the_patients_record_and_its_files_download(uninterrupted, phone):
    finished, _, result = uninterrupted
    feed = phone.get("/api/v1/sync/changes?since=0&limit=500", "change feed")
    analyses = [c for c in feed["changes"] if c["meta"]["kind"] == "burn_analysis"]
    mine = [c for c in analyses if c["meta"]["id"] == finished["id"]]
    assert len(mine) == 1 and mine[0]["data"]["encounter_id"] == finished["encounter_id"]
    assert mine[0]["data"]["result"]["metrics"] == result["metrics"] and mine[0]["meta"]["updated_by"] == "gateway"
    files = phone.get(f"/api/v1/analyses/{finished['id']}/artifacts", "artifacts")
    assert {"analysis.json", "surface/burn_surface.glb", "mesh/surface.glb"} <= set(files)
    assert any(f.startswith("segmentation/overlays/") for f in files)
    glb = phone.http.get(f"/api/v1/analyses/{finished['id']}/artifacts/surface/burn_surface.glb")
    assert glb.status_code == 200 and glb.content[:4] == b"glTF"
    assert phone.http.get(f"/api/v1/analyses/{finished['id']}/artifacts/sfm/database.db").status_code == 404


def test_the_healing_track_links_the_analysis_and_shows_no_server_paths(uninterrupted, phone, gateway):
    finished, _, result = uninterrupted
    url = f"/api/v1/patients/{finished['patient_id']}/healing"
    # A patient with no wound recorded: the analysis sits in the section of analyses of no wound.
    wait_for(lambda: (phone.http.get(url).json()["wounds"] or [{}])[0].get("track"), 60, "the healing track")
    response = phone.http.get(url)
    [section] = response.json()["wounds"]
    assert section["wound_id"] is None and finished["wound_id"] is None
    [visit] = section["track"]["sessions"]
    assert visit["analysis"] == f"/api/v1/analyses/{finished['id']}" and visit["label"] == "day 0"
    assert visit["day"] == pytest.approx(result["hours_since_injury"] / 24, abs=0.01)  # the analysis and track agree
    assert str(gateway.db.parent) not in response.text and '"/tmp' not in response.text


def analysis_at_dense(gateway: GatewayProcess, phone: GatewayClient, phantom: Path) -> tuple[dict, int, int]:
    """A new visit's analysis (true masks) once it reaches the dense stage: (job, worker pid, analysis pid)."""
    enc, assets = new_visit(phone, phantom)
    requested = phone.post(f"/api/v1/encounters/{enc}/analyses", true_masks(phantom, assets), "request")
    at_stage(phone, requested["id"], "dense")
    [worker] = children(gateway.proc.pid)
    [analysis] = children(worker)
    return requested, worker, analysis


def test_a_worker_killed_mid_reconstruction_resumes_and_gives_the_same_metrics(uninterrupted, gateway, phone, phantom):
    _, _, reference = uninterrupted
    requested, worker, analysis = analysis_at_dense(gateway, phone, phantom)
    os.kill(worker, signal.SIGKILL)
    wait_for(lambda: not alive(analysis), 10, "the analysis process to die with its worker")
    last = GatewayClient.follow(phone, requested["id"], lambda e: None)
    assert last["state"] == "done", last
    finished = job(phone, requested["id"])
    assert finished["attempts"] == 2
    assert finished["history"] == [
        "try 1 lost its worker (killed, power cut or out of memory) in the dense stage; retried from dense"
    ]
    first, second = phone.get(f"/api/v1/analyses/{requested['id']}/attempts", "attempts")
    assert (first["outcome"], first["stage"], second["outcome"], second["resumed_from"]) == (
        "lost",
        "dense",
        "done",
        "dense",
    )
    result = phone.get(f"/api/v1/analyses/{requested['id']}/result", "result")
    # Resumed: SfM was not run again; its time is the one it took in the first try.
    assert "sfm" in result["reused_stages"] and result["timings_s"]["sfm"] > 0
    assert "dense" not in result["reused_stages"]
    for name in ("area_cm2", "perimeter_cm", "relief_max_mm", "volume_cm3"):
        assert result["metrics"][name] == pytest.approx(reference["metrics"][name], rel=0.01), name
    feed = phone.get("/api/v1/sync/changes?since=0&limit=500", "change feed")
    assert sum(c["meta"]["id"] == requested["id"] for c in feed["changes"]) == 1  # stored once


def test_a_native_crash_of_the_analysis_is_retried_and_said(gateway, phone, phantom):
    """SIGSEGV in the analysis process (as Open3D once did in meshing): the queue retries from that stage, and the
    job, its attempts and the worker's log say what happened, with the Python stack that led into it."""
    requested, worker, analysis = analysis_at_dense(gateway, phone, phantom)
    os.kill(analysis, signal.SIGSEGV)
    last = GatewayClient.follow(phone, requested["id"], lambda e: None)
    assert last["state"] == "done", last
    said = "try 1 ended by SIGSEGV in the dense stage"
    finished = job(phone, requested["id"])
    assert finished["history"] == [f"{said}; retried from dense"] and finished["error"] is None
    crashed, done = phone.get(f"/api/v1/analyses/{requested['id']}/attempts", "attempts")
    assert (crashed["outcome"], crashed["exit"], crashed["stage"]) == ("crashed", "SIGSEGV", "dense")
    tail = crashed["log_tail"]
    assert "Segmentation fault" in tail and "File " in tail  # faulthandler: the Python stack
    assert "SIGSEGV" in tail  # COLMAP glog: the native one
    assert "/site-packages/" not in tail and str(gateway.db.parent) not in tail
    assert done["outcome"] == "done" and done["resumed_from"] == "dense"
    worker_log = gateway.log.read_text(errors="replace")
    assert said in worker_log and "Segmentation fault" in worker_log


def test_cancelling_a_running_analysis_stops_its_process(gateway, phone, phantom):
    enc, _ = new_visit(phone, phantom, mode="consultation")
    requested = phone.post(f"/api/v1/encounters/{enc}/analyses", {}, "request")
    at_stage(phone, requested["id"], "sfm")
    [worker] = children(gateway.proc.pid)
    [analysis] = children(worker)
    phone.post(f"/api/v1/analyses/{requested['id']}/cancel", {}, "cancel")
    wait_for(lambda: job(phone, requested["id"])["state"] == "cancelled", 10, "the cancel")
    wait_for(lambda: not alive(analysis), 10, "the analysis process to stop")
    assert alive(worker)  # the worker itself goes on to the next job
    assert phone.http.get(f"/api/v1/analyses/{requested['id']}/result").status_code == 409


def test_sigkill_of_the_whole_gateway_with_three_queued_jobs(tmp_path, phantom):
    gw = GatewayProcess(tmp_path / "gw.sqlite3", free_port())
    gw.env = dict(FAST_QUEUE)
    add_user_cli(gw.db, "dr.kill", "clinician")
    gw.start()
    phone = GatewayClient(gw.url)
    try:
        phone.http.headers.update(login(phone.http, "dr.kill"))
        enc, assets = new_visit(phone, phantom)
        stems = sorted(assets)
        # Three different picture sets of one visit (five of its eight pictures each): three analyses.
        ids = [
            phone.post(
                f"/api/v1/encounters/{enc}/analyses",
                {"assets": [assets[s] for s in stems if s not in stems[first : first + 3]]},
                "request",
            )["id"]
            for first in range(3)
        ]
        at_stage(phone, ids[0], "sfm")
        [worker] = children(gw.proc.pid)
        [analysis] = children(worker)
        os.kill(gw.proc.pid, signal.SIGKILL)
        gw.proc.wait()
        wait_for(lambda: not alive(worker) and not alive(analysis), 15, "the worker and its analysis to stop")
        gw.start()
        for job_id in ids:
            assert phone.follow(job_id, lambda e: None)["state"] == "done"
        feed = phone.get("/api/v1/sync/changes?since=0&limit=500", "change feed")
        stored = [c["meta"]["id"] for c in feed["changes"] if c["meta"]["kind"] == "burn_analysis"]
        assert sorted(stored) == sorted(ids)
    finally:
        phone.close()
        gw.stop()
