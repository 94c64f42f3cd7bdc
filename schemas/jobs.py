"""Analyses on the gateway: the request a phone sends, the queued job it becomes, and the stored result.

A job moves queued -> running -> done | failed | cancelled. A running job is held by one worker under a
lease it renews; a worker that dies loses the lease and the job is queued again, to resume from its last
finished stage.
"""

from __future__ import annotations

import enum
import re
from typing import Annotated

import msgspec

from schemas.analysis import AnalysisResult
from schemas.base import Frozen, Id, ShortText

Pixel = Annotated[list[float], msgspec.Meta(min_length=2, max_length=2)]


class JobState(enum.StrEnum):
    queued = "queued"
    """Waiting for a worker (also after a retry was scheduled: see next_attempt_at)."""
    running = "running"
    done = "done"
    """The analysis finished and its result is stored (its status may still be 'unscaled')."""
    failed = "failed"
    """No result: `error` says why and what to do."""
    cancelled = "cancelled"


FINISHED = frozenset({JobState.done, JobState.failed, JobState.cancelled})


class CaptureTimeSource(enum.StrEnum):
    camera = "camera"
    """The pictures' own clock: EXIF DateTimeOriginal, or a video's creation time."""
    upload = "upload"
    """When the gateway received the pictures: they carry no plausible time of their own."""


class CaptureTime(Frozen):
    """When a visit's pictures were taken: the analysis counts the hours since injury to it."""

    at: str
    """ISO 8601, UTC: the earliest picture's (a later one would make the burn look older than it is)."""
    source: CaptureTimeSource
    detail: str
    """What the pictures said, for people: e.g. 'camera clock of 8 of 8 pictures'."""


class AttemptOutcome(enum.StrEnum):
    running = "running"
    done = "done"
    """The analysis finished (its result may still be 'failed': the capture could not be measured)."""
    failed = "failed"
    """Bad input or data: not tried again."""
    crashed = "crashed"
    """The process died or stopped on an unexpected error: tried again from its last finished stage."""
    hung = "hung"
    lost = "lost"
    """Its worker died or lost the lease."""
    handed_back = "handed_back"
    """Its worker was stopped: queued again at once, not counted as a try."""
    cancelled = "cancelled"


class JobAttempt(Frozen):
    """One try of an analysis job (GET /api/v1/analyses/{id}/attempts)."""

    attempt: int
    started_at: str
    outcome: AttemptOutcome
    ended_at: str | None = None
    stage: str = ""
    """The stage it was in when it ended."""
    resumed_from: str = ""
    """The stage it started at ('' for the first: from the beginning)."""
    exit: str = ""
    """How its process ended: 'exit code 1', 'SIGSEGV', ... ('' while running or when it ended normally)."""
    reason: str = ""
    """Why it ended, in words."""
    log_tail: str = ""
    """The last lines its process wrote (native crashes print only there)."""


class MaskInput(Frozen):
    """A clinician's burn mask or outline for one picture; it replaces the model's for that picture."""

    asset_id: Id
    """The photo or frame it was drawn on."""
    png_base64: str | None = None
    """8-bit PNG, white (>= 128) = burn, the size of the picture as stored."""
    polygons: list[Annotated[list[Pixel], msgspec.Meta(min_length=3)]] | None = None
    """Outline(s) as [[x, y], ...] in pixels of the picture as stored; used when no PNG is given."""


class RulerMarkInput(Frozen):
    """The two ruler points as clicked in one picture (pixels as stored, origin top-left)."""

    asset_id: Id
    a: Pixel
    b: Pixel


class RulerInput(Frozen):
    """Scale without the printed marker: two points of known distance marked in two or more pictures."""

    distance_mm: Annotated[float, msgspec.Meta(gt=0, le=2000)]
    marks: Annotated[list[RulerMarkInput], msgspec.Meta(min_length=2)]


class AnalysisRequest(Frozen):
    """POST /api/v1/encounters/{id}/analyses: analyse the encounter's capture set."""

    assets: list[Id] | None = None
    """Photos and frames to use; None uses every photo and frame of the encounter (the quality gate still
    leaves out unusable ones)."""
    masks: list[MaskInput] = msgspec.field(default_factory=list)
    ruler: RulerInput | None = None
    marker_side_mm: Annotated[float, msgspec.Meta(gt=0, le=500)] | None = None
    """Printed side of each marker square when it is not the configured one (20 mm by default)."""
    wound_id: Id | None = None
    """The wound measured: its pictures in the encounter are used unless `assets` names them. Required when the
    patient has more than one open wound; left out, a patient's only wound (or only open one) is meant."""


class AnalysisJob(Frozen):
    """An analysis request as the queue holds it (GET /api/v1/analyses/{id})."""

    id: str
    encounter_id: str
    patient_id: str
    state: JobState
    priority: int
    """0 for emergency encounters, 1 for consultations: lower runs first, then oldest first."""
    stage: str = ""
    """The stage running or last finished: inputs, sfm, scale, dense, mesh, segment, surface, metrics."""
    fraction: float = 0.0
    """Share of the work done, 0..1 (by the stages' typical durations)."""
    message: str = ""
    """What is happening, for the person waiting."""
    attempts: int = 0
    """Tries started so far (a worker that died counts as one)."""
    max_attempts: int = 3
    next_attempt_at: str | None = None
    """When a queued retry may start."""
    error: str | None = None
    """Why the job failed, or why the last try did."""
    cancel_requested: bool = False
    pictures: int = 0
    created_at: str = ""
    created_by: ShortText = ""
    started_at: str | None = None
    finished_at: str | None = None
    queue_position: int | None = None
    """1 = next to run; None unless queued."""
    result_status: str | None = None
    """Once done: 'ok' (measured in mm and cm) or 'unscaled'; 'failed' when the capture could not be measured."""
    captured: CaptureTime | None = None
    """When the pictures were taken (None for jobs an older gateway queued)."""
    wound_id: str | None = None
    """The wound measured; None for a patient who had no wound recorded when it was asked for."""
    history: list[str] = msgspec.field(default_factory=list)
    """How each earlier try ended, in words ('try 1 ended by SIGSEGV in the mesh stage; retried from mesh');
    the details are at /attempts."""


class StoredJob(Frozen):
    """A row of `analysis_jobs` as the queue keeps it, all but its `request` (a JobInputs, read on its own).
    AnalysisJob is what the API shows of it."""

    id: str
    encounter_id: str
    patient_id: str
    input_digest: str
    """What makes two requests the same analysis (gateway/analyses/service.py)."""
    state: JobState
    priority: int
    max_attempts: int
    next_attempt_at: str
    pictures: int
    created_at: str
    created_by: str
    user_id: str
    stage: str = ""
    fraction: float = 0.0
    message: str = ""
    attempts: int = 0
    lease_owner: str | None = None
    lease_expires_at: str | None = None
    cancel_requested: bool = False
    error: str | None = None
    result_status: str | None = None
    started_at: str | None = None
    finished_at: str | None = None
    cleaned_at: str | None = None
    """When the retention clean-up removed its work files."""
    captured: CaptureTime | None = None
    wound_id: str | None = None


class JobEvent(Frozen):
    """One server-sent event of GET /api/v1/analyses/{id}/events (event type 'progress', then 'end')."""

    id: str
    state: JobState
    stage: str
    fraction: float
    message: str
    error: str | None = None
    result_status: str | None = None
    heading: str = ""
    """The state in words, the step and the time left: "Building the surface…, step 4 of 8, about 40 s left"."""
    step: int | None = None
    steps: int = 0
    remaining_s: float | None = None
    """Seconds left by the stage times this gateway has measured (None until it has finished an analysis)."""


class BurnAnalysis(Frozen):
    """The `burn_analysis` record: a finished analysis in the patient's record (written by the gateway only)."""

    encounter_id: Id
    job_id: str
    assets: list[str]
    """The photos and frames it was asked to use."""
    requested_by: ShortText
    requested_at: str
    completed_at: str
    result: AnalysisResult
    """The measurement with its confidence, scale, provenance and notes; decision support only."""
    captured: CaptureTime | None = None
    """When the pictures were taken: result.hours_since_injury counts to it."""
    wound_id: str | None = None
    """The wound measured (None: asked for before wounds were kept, or for a patient with none recorded; the
    analysis job's row holds the wound the upgrade gave it)."""


class PictureRef(Frozen):
    """A picture of a job, as the gateway stores it."""

    asset_id: str
    sha256: str
    suffix: str
    """File suffix for its media type (.jpg, .png, .heic)."""
    filename: str = ""
    """The name the phone gave (for people: the analysis names its files after it, with the asset id's end)."""

    @property
    def stem(self) -> str:
        """The name of its files in the analysis: 'view_003-1a2b3c4d', or the asset id for jobs without a name."""
        name = re.sub(r"[^A-Za-z0-9_-]+", "_", self.filename.rsplit(".", 1)[0]).strip("_")[:40]
        return f"{name}-{self.asset_id[-8:]}" if name else self.asset_id


class JobInputs(Frozen):
    """What a job analyses (the `request` column of analysis_jobs): the request with its pictures resolved."""

    pictures: list[PictureRef]
    masks: list[MaskInput] = msgspec.field(default_factory=list)
    ruler: RulerInput | None = None
    marker_side_mm: float | None = None
    requested_at: str = ""
    captured: CaptureTime | None = None
    """None in jobs queued before capture times were kept: the hours since injury then count to requested_at."""
