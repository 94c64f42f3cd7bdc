"""Stage: a patient's analyses of one burn over time -> out_dir/track.json.

    run(conf, sessions, out_dir) -> out_dir/track.json

The baseline is the first visit with a result in real units. Every later such visit is registered to it on
healthy skin (registration.py) and compared with it; the healing rate, the projected closure and the review
prompts come from every measured visit (healing.py). Failed, unscaled or missing analyses are listed with their
status and no figures. Registrations are cached in out_dir/registrations/, keyed by a digest of both surfaces,
the settings and the registration code, so a rerun with one more visit registers only the new one.
"""

from __future__ import annotations

import hashlib
import logging
import math
from dataclasses import dataclass
from pathlib import Path

import msgspec
import numpy as np

from processing.longitudinal import healing, registration
from processing.stages import write_json
from schemas.analysis import AnalysisResult, AnalysisStatus
from schemas.config import TrackingConfig
from schemas.errors import InvalidInput
from schemas.longitudinal import Registration, TrackResult, TrackSession
from schemas.reconstruction import FailureCode

log = logging.getLogger(__name__)

RESULT = "track.json"
CACHE = "registrations"
SURFACE = Path("surface") / "burn_surface.npz"
MESH = Path("mesh") / "surface.ply"
HEALING_SETTINGS = ("stall_reduction_percent", "stall_after_days", "healing_deadline_day", "healed_area_cm2")
"""Settings that change no registration (left out of the cache key)."""


@dataclass(frozen=True)
class SessionAnalysis:
    """One visit: its day (days since the injury, or since the first visit when the injury day is unknown) and
    the folder `burnedge analyze` (or the gateway) wrote its analysis into."""

    day: float
    analysis_dir: Path
    label: str = ""


def _file_digest(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _surface_digest(folder: Path) -> str:
    mesh = folder / MESH
    return _file_digest(folder / SURFACE) + (_file_digest(mesh) if mesh.is_file() else "")


def cache_key(conf: TrackingConfig, baseline_dir: Path, follow_dir: Path) -> str:
    settings = {k: v for k, v in msgspec.to_builtins(conf).items() if k not in HEALING_SETTINGS}
    code = Path(registration.__file__).read_bytes()
    parts = [
        _surface_digest(baseline_dir),
        _surface_digest(follow_dir),
        msgspec.json.encode(settings).decode(),
        hashlib.sha256(code).hexdigest(),
    ]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:32]


class _Registrar:
    """Registers visits to one baseline, through the cache."""

    def __init__(self, conf: TrackingConfig, baseline_dir: Path, cache_dir: Path):
        self.conf, self.baseline_dir, self.cache_dir = conf, baseline_dir, cache_dir
        self._baseline: registration.Surface | None = None

    def __call__(self, follow_dir: Path) -> Registration:
        path = self.cache_dir / f"{cache_key(self.conf, self.baseline_dir, follow_dir)}.json"
        if path.is_file():
            try:
                cached = msgspec.json.decode(path.read_bytes(), type=Registration)
                return msgspec.structs.replace(cached, seconds=0.0)
            except (msgspec.ValidationError, msgspec.DecodeError):
                log.warning("cached registration %s is unreadable: registering again", path)
        if self._baseline is None:
            self._baseline = registration.load_surface(self.baseline_dir / SURFACE, self.baseline_dir / MESH)
        follow = registration.load_surface(follow_dir / SURFACE, follow_dir / MESH)
        result = registration.register(self.conf, self._baseline, follow)
        write_json(path, result)
        return result


def _read(session: SessionAnalysis) -> tuple[AnalysisResult | None, str]:
    path = session.analysis_dir / "analysis.json"
    if not path.is_file():
        return None, f"no analysis.json in {session.analysis_dir} (not analysed yet?)"
    try:
        return msgspec.json.decode(path.read_bytes(), type=AnalysisResult), ""
    except (msgspec.ValidationError, msgspec.DecodeError) as exc:
        return None, f"{path} is unreadable ({exc})"


def check_sessions(sessions: list[SessionAnalysis]) -> None:
    if not sessions:
        raise InvalidInput("no visits to track")
    days = [s.day for s in sessions]
    if not all(math.isfinite(d) for d in days):
        raise InvalidInput(f"every visit needs a finite day, got {days}")
    for earlier, later in zip(sessions, sessions[1:], strict=False):
        if later.day < earlier.day:
            raise InvalidInput(
                f"visits must be in time order: day {later.day:g} ({later.label or later.analysis_dir}) "
                f"comes after day {earlier.day:g}"
            )


def _r(value: float | None, digits: int) -> float | None:
    return None if value is None else round(value, digits)


def _figures(result: AnalysisResult) -> healing.Figures:
    m = result.metrics
    return healing.Figures(area_cm2=m.area_cm2, relief_max_mm=m.relief_max_mm, volume_cm3=m.volume_cm3)


def run(conf: TrackingConfig, sessions: list[SessionAnalysis], out_dir: Path) -> Path:
    """Compare every visit with the baseline, fit the healing rate and write out_dir/track.json (atomically)."""
    check_sessions(sessions)
    out_dir = Path(out_dir)
    read = [_read(s) for s in sessions]
    measured = [
        i
        for i, (r, _) in enumerate(read)
        if r is not None
        and r.status is AnalysisStatus.ok
        and r.metrics.area_cm2 is not None
        and (sessions[i].analysis_dir / SURFACE).is_file()
    ]
    notes: list[str] = []
    base = measured[0] if measured else None
    registrar = _Registrar(conf, sessions[base].analysis_dir, out_dir / CACHE) if base is not None else None
    rows = []
    for i, (session, (result, problem)) in enumerate(zip(sessions, read, strict=True)):
        label = session.label or session.analysis_dir.name
        common = {"day": session.day, "label": label, "analysis": str(session.analysis_dir)}
        if result is None:
            rows.append(TrackSession(**common, status="missing", reason=problem))
            continue
        if i not in measured:
            if result.status is AnalysisStatus.unscaled:
                reason = (
                    "unscaled analysis (no marker or ruler in the photos): its sizes are not in mm or cm, so it "
                    "is neither registered nor compared"
                )
            elif result.status is AnalysisStatus.failed:
                reason = f"analysis failed: {result.reason}"
                if result.failure is FailureCode.no_burn and base is not None and i > base:
                    notes.append(
                        f"day {session.day:g}: no burn was found in the photos; if the wound has closed, "
                        "record it on examination (healing is not inferred from a missing measurement)"
                    )
            else:
                reason = "the analysis left no burn surface to compare (run it again)"
            rows.append(TrackSession(**common, status=result.status.value, reason=reason))
            continue
        m = result.metrics
        figures = {
            "area_cm2": m.area_cm2,
            "perimeter_cm": m.perimeter_cm,
            "relief_max_mm": m.relief_max_mm,
            "volume_cm3": m.volume_cm3,
            "confidence_level": result.confidence.level if result.confidence else None,
        }
        if i == base:
            rows.append(
                TrackSession(
                    **common,
                    **figures,
                    status=result.status.value,
                    baseline=True,
                    registration_rmse_mm=0.0,
                    registration_overlap=1.0,
                    area_change_cm2=0.0,
                    area_change_percent=0.0,
                    percent_area_reduction=0.0,
                    relief_change_mm=0.0 if m.relief_max_mm is not None else None,
                    volume_change_cm3=0.0 if m.volume_cm3 is not None else None,
                    transform_to_baseline=np.eye(4).tolist(),
                )
            )
            continue
        delta = healing.change(_figures(read[base][0]), _figures(result))
        try:
            fit = registrar(session.analysis_dir)
            registered = {
                "registration_rmse_mm": fit.rmse_mm,
                "registration_overlap": fit.overlap,
                "registration_warning": fit.warning,
                "transform_to_baseline": fit.transform_to_baseline,
            }
        except InvalidInput as exc:  # CaptureInsufficient too: too little skin; the figures still stand
            registered = {"registration_warning": f"not registered: {exc.detail}"}
        rows.append(
            TrackSession(
                **common,
                **figures,
                **registered,
                status=result.status.value,
                area_change_cm2=_r(delta.area_change_cm2, 3),
                area_change_percent=_r(delta.area_change_percent, 2),
                percent_area_reduction=_r(delta.percent_area_reduction, 2),
                relief_change_mm=_r(delta.relief_change_mm, 2),
                volume_change_cm3=_r(delta.volume_change_cm3, 3),
            )
        )

    days = [sessions[i].day for i in measured]
    areas = [read[i][0].metrics.area_cm2 for i in measured]
    if base is None:
        notes.append("no visit has a result in real units (mm, cm2): nothing to compare; see each visit's reason")
    elif base > 0:
        notes.append(
            f"the baseline is visit {base + 1} (day {sessions[base].day:g}), the first with a result in real "
            "units; earlier visits are listed without figures"
        )
    rate = healing.healing_rate(days, areas)
    projection = healing.projected_closure(rate)
    track = TrackResult(
        sessions=rows,
        healing_rate_cm2_per_day=_r(rate.rate_cm2_per_day, 4),
        healing_rate_se_cm2_per_day=_r(rate.se_cm2_per_day, 4),
        projected_closure_day=_r(projection.day, 1),
        projected_closure_range_days=None
        if projection.day is None
        else [_r(projection.earliest, 1), _r(projection.latest, 1)],
        projection_note=projection.note,
        stall_flags=healing.stall_flags(conf, days, areas, projection),
        notes=notes,
    )
    path = write_json(out_dir / RESULT, track)
    log.info(
        "track: %d visits, %d measured, rate %s cm2/day",
        len(sessions),
        len(measured),
        "-" if rate.rate_cm2_per_day is None else f"{rate.rate_cm2_per_day:.3f}",
    )
    return path
