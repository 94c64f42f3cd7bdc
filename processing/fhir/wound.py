"""An analysed burn as FHIR R4: a WoundSize panel (HL7 Skin Wound Assessment IG) derived from the Media of the
photos it used, and the painted 3D surface and the report as DocumentReferences.

Files are not put inside the Bundle: each attachment gives its URL relative to the gateway, its content type,
size and SHA-1 (FHIR's Attachment.hash), and its SHA-256 as an identifier, so a receiver can fetch it and check
it is the file this Bundle describes.
"""

from __future__ import annotations

import base64
import hashlib
from dataclasses import dataclass
from pathlib import Path

from processing.fhir import codes
from processing.fhir.codes import concept
from processing.fhir.record import iso, quantity, ref, resource_id
from schemas.analysis import AnalysisStatus, ModelSummary
from schemas.encounter_snapshot import AnalysisVisit
from schemas.segmentation import MaskSource

RELIEF_TEXT = (
    "Surface relief: the deepest point of the burn's surface below a surface fitted to the healthy skin around "
    "it, measured in 3D from photographs. Geometry, not the clinical burn depth (the Conditions' code gives the "
    "clinician's depth category)."
)
VOLUME_TEXT = "Sunken volume between the fitted healthy-skin surface and the burn's surface: a proxy, not tissue loss."


@dataclass(frozen=True)
class Attached:
    """A file the Bundle points to, served by the gateway at `url` (relative to the gateway)."""

    url: str
    content_type: str
    size: int
    sha1_base64: str
    sha256: str
    title: str
    created: str | None = None


def attached(path: Path, url: str, content_type: str, title: str, created: str | None = None) -> Attached:
    data = path.read_bytes()
    sha1 = base64.b64encode(hashlib.sha1(data, usedforsecurity=False).digest()).decode()
    return Attached(url, content_type, len(data), sha1, hashlib.sha256(data).hexdigest(), title, created)


def _attachment(file: Attached) -> dict:
    out = {"contentType": file.content_type, "url": file.url, "size": file.size, "hash": file.sha1_base64}
    out |= {"title": file.title} | ({"creation": file.created} if file.created else {})
    return out


def _sha256_identifier(file: Attached) -> dict:
    """The file's SHA-256 as an RFC 6920 name (base64url, no padding)."""
    digest = base64.urlsafe_b64encode(bytes.fromhex(file.sha256)).decode().rstrip("=")
    return {"system": "urn:ietf:rfc:3986", "value": f"ni:///sha-256;{digest}"}


def media(file: Attached, subject: dict, enc: dict, job_id: str) -> dict:
    out = {
        "resourceType": "Media",
        "id": resource_id("media", job_id, file.sha256),
        "identifier": [_sha256_identifier(file)],
        "status": "completed",
        "type": concept((codes.MEDIA_TYPE, "image", "Image")),
        "subject": subject,
        "encounter": enc,
        "content": _attachment(file),
    }
    if file.created:
        out["createdDateTime"] = file.created
    return out


def document(file: Attached, kind: str, subject: dict, enc: dict, description: str, of: str = "") -> dict:
    """`of` names what the document belongs to (an analysis's job id): two analyses of the same photos paint the
    same surface, and each needs its own resource."""
    return {
        "resourceType": "DocumentReference",
        "id": resource_id("document", kind, file.sha256, *([of] if of else [])),
        "identifier": [_sha256_identifier(file)],
        "status": "current",
        "type": {"text": kind},
        "subject": subject,
        "description": description,
        "content": [{"attachment": _attachment(file)}],
        "context": {"encounter": [enc]},
    }


def mask_method(page: AnalysisVisit, model: ModelSummary | None) -> str:
    views = page.analysis.value.result.views
    drawn = sum(v.source is not MaskSource.model for v in views)
    by_model = len(views) - drawn
    parts = []
    if by_model:
        name = f"the segmentation model {model.version}" if model and model.version else "burnedge's segmentation model"
        parts.append(f"{by_model} by {name}" + (f" (sha256 {model.sha256})" if model else ""))
    if drawn:
        parts.append(f"{drawn} drawn by a clinician")
    return "burn outline on the photos: " + ("; ".join(parts) or "none")


def _confidence_note(page: AnalysisVisit) -> str:
    result = page.analysis.value.result
    conf = result.confidence
    if conf is None:
        return "Confidence: not scored."
    reasons = "; ".join(conf.reasons) if conf.reasons else "no reason to doubt the figures was found"
    return f"Confidence {conf.level} ({conf.score:.2f} of 1): {reasons}."


def wound_size(page: AnalysisVisit, subject: dict, enc: dict, photos: list[dict], model: ModelSummary | None) -> dict:
    """The WoundSize panel of one analysed burn: area, surface relief (as geometry) and volume in UCUM units,
    never a figure in cm without a metric scale."""
    value = page.analysis.value
    result, m = value.result, value.result.metrics
    hours = result.hours_since_injury
    provisional = result.provisional is not False
    components = []
    notes = [_confidence_note(page)]
    if m.area_cm2 is not None:
        components.append({"code": concept(codes.WOUND_AREA), "valueQuantity": quantity(m.area_cm2, "cm2")})
    if m.relief_max_mm is not None and m.relief_max_mm > 0:
        depth = concept(codes.WOUND_DEPTH, text=RELIEF_TEXT)
        components.append({"code": depth, "valueQuantity": quantity(m.relief_max_mm / 10, "cm", 3)})
        notes.append("Surface relief (component 39127-6) is a geometric measure of the skin surface, not a burn depth.")
    elif m.relief_max_mm is not None:
        notes.append(
            "The burn's surface is not below the healthy skin around it (raised or level): no relief is given."
        )
    if m.volume_cm3 is not None:
        volume = concept(codes.WOUND_VOLUME, text=VOLUME_TEXT)
        components.append({"code": volume, "valueQuantity": quantity(m.volume_cm3, "mL", 3)})
    if m.perimeter_cm is not None:
        components.append({"code": concept(codes.WOUND_PERIMETER), "valueQuantity": quantity(m.perimeter_cm, "cm")})
    notes.append("Length and width are not measured by burnedge: they are left out.")
    notes += list(result.notes)  # the analysis's own caveats travel with its figures, as in the report
    if result.status is AnalysisStatus.failed:
        notes.insert(0, f"The analysis failed: {result.reason or 'no reason recorded'}. No figure is given.")
    elif not components and (result.scale is None or not result.scale.mm_per_unit):
        notes.insert(0, "No metric scale was found in the photos: no figure in cm, cm2 or mL is given.")
    if provisional:
        when = f"{hours:.0f} h after the injury" if hours is not None else "at an unknown time after the injury"
        notes.insert(0, f"Provisional: photos taken {when}; burns evolve over the first 72 h: measure again.")
    out = {
        "resourceType": "Observation",
        "id": resource_id("wound-size", value.job_id, str(page.analysis.ref.version)),
        "meta": {"profile": [codes.WOUND_SIZE_PROFILE], "versionId": str(page.analysis.ref.version)},
        "identifier": [{"system": f"{codes.LOCAL_ID}/burn-analysis", "value": value.job_id}],
        "status": "preliminary" if provisional else "final",
        "category": [concept((codes.OBSERVATION_CATEGORY, "exam", "Exam"))],
        "code": concept(codes.WOUND_SIZE),
        "subject": subject,
        "encounter": enc,
        "effectiveDateTime": iso(value.captured.at) if value.captured else value.completed_at,
        "issued": value.completed_at,
        "method": concept(
            codes.PHOTOGRAMMETRY, text=f"3D surface from {len(value.assets)} photographs; {mask_method(page, model)}"
        ),
        "note": [{"text": n} for n in notes],
    }
    if photos:
        out["derivedFrom"] = [ref(p) for p in photos]
    if provisional:
        out["interpretation"] = [{"text": "provisional (under 72 h after the injury, or time unknown)"}]
    if components:
        out["component"] = components
    return out
