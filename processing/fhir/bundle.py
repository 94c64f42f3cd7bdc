"""One encounter as a FHIR R4 Bundle (type collection), made from the same snapshot of record versions as the
clinical report, and validated resource by resource with fhir.resources' R4B models before it leaves.

    build(inputs, files) -> dict (FHIR JSON)
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field

from processing.fhir import codes, consent, history, record, wound
from processing.fhir.codes import concept
from processing.fhir.record import iso, ref, resource_id
from processing.fhir.wound import Attached
from processing.fhir.wound_condition import wound_conditions
from schemas.analysis import ModelSummary
from schemas.encounter_snapshot import EncounterSnapshot
from schemas.errors import BurnedgeError

FHIR_JSON = "application/fhir+json"


class InvalidFhir(BurnedgeError):
    """The Bundle made does not validate against the FHIR models: a fault in burnedge, never sent."""


@dataclass(frozen=True)
class AnalysisFiles:
    """What one analysis's resources point to."""

    photos: list[Attached]
    surface: Attached | None = None
    """The painted burn surface (GLB)."""
    model: ModelSummary | None = None
    """The segmentation model behind its masks (None when people drew every mask)."""


@dataclass(frozen=True)
class BundleFiles:
    analyses: dict[str, AnalysisFiles] = field(default_factory=dict)
    """By analysis job id."""
    report: Attached | None = None
    """The clinical report (PDF) made from the same record versions."""


def _analysis_resources(
    inputs: EncounterSnapshot, files: BundleFiles, subject: dict, enc: dict, wounds: dict[str, dict]
) -> list[dict]:
    out = []
    for page in inputs.analyses:
        job_id = page.analysis.value.job_id
        found = files.analyses.get(job_id, AnalysisFiles(photos=[]))
        visit_id = page.analysis.value.encounter_id
        visit = enc
        if visit_id != inputs.encounter.value.id:  # another visit's encounter: named, not in this Bundle
            visit = {"identifier": record.record_identifier("encounter", visit_id), "display": page.visit}
        photos = [wound.media(p, subject, visit, job_id) for p in found.photos]
        size = wound.wound_size(page, subject, visit, photos, found.model)
        condition = wounds.get(page.wound_id or "")
        if condition is not None:  # the wound this panel measures
            size["focus"] = [ref(condition)]
            size["bodySite"] = condition["bodySite"][0] if condition["bodySite"] else {"text": page.wound}
        out += photos + [size]
        if found.surface:
            text = f"Painted 3D burn surface of the analysis of {page.visit} (glTF binary)"
            out.append(wound.document(found.surface, "3D burn surface", subject, visit, text, of=job_id))
    return out


def _provenance(inputs: EncounterSnapshot, files: BundleFiles, targets: list[dict]) -> dict:
    agents = [
        {
            "type": concept((codes.PROVENANCE_AGENT, "assembler", "Assembler")),
            "who": {
                "display": f"burnedge {inputs.software_version}" + (f" at {inputs.clinic}" if inputs.clinic else "")
            },
        }
    ]
    authors = [inputs.encounter.value.clinician] + [a.analysis.value.requested_by for a in inputs.analyses]
    confirmed = []
    if inputs.decision_support:
        confirmed = [r.decided_by for r in inputs.decision_support.value.recommendations if r.decided_by]
    for role, names in (("author", authors), ("verifier", confirmed)):
        for name in dict.fromkeys(n for n in names if n):
            agents.append({"type": concept((codes.PROVENANCE_AGENT, role, role.title())), "who": {"display": name}})
    models = {f.model.sha256: f.model for f in files.analyses.values() if f.model}
    entities = [
        {
            "role": "source",
            "what": {"display": f"segmentation model {m.version or '(unversioned)'} (sha256 {m.sha256})"},
        }
        for m in models.values()
    ]
    out = {
        "resourceType": "Provenance",
        "id": resource_id("provenance", inputs.report_id),
        "target": [ref(t) for t in targets],
        "recorded": iso(inputs.made_at),
        "agent": agents,
    }
    if entities:
        out["entity"] = entities
    return out


def build(inputs: EncounterSnapshot, files: BundleFiles) -> dict:
    """The Bundle of the encounter in `inputs` and its patient's measured visits."""
    patient = record.patient(inputs.patient)
    subject = ref(patient)
    enc = {"reference": f"urn:uuid:{resource_id('encounter', inputs.encounter.value.id)}"}
    conditions = record.conditions(inputs.chart, inputs.encounter, subject)
    wounds = wound_conditions(inputs.wounds, subject)
    resources = [patient, record.encounter(inputs.encounter, subject, conditions), *conditions, *wounds.values()]
    resources += history.allergies(inputs.intake, subject, enc) + history.medications(inputs.intake, subject, enc)
    resources += history.tetanus(inputs.intake, inputs.encounter, subject, enc)
    resources += record.assessment_observations(inputs.assessment, inputs.chart, inputs.encounter, subject, enc)
    resources += _analysis_resources(inputs, files, subject, enc, wounds)
    resources += record.communications(inputs.consultations, subject, enc)
    if shared := consent.consent(inputs.encounter, subject):
        resources.append(shared)
    if files.report:
        text = f"Clinical report {inputs.report_id}, made {iso(inputs.made_at)} by {inputs.made_by}"
        resources.append(wound.document(files.report, "Burn assessment report", subject, enc, text))
    resources.append(_provenance(inputs, files, resources))
    bundle = {
        "resourceType": "Bundle",
        "id": resource_id("bundle", inputs.report_id),
        "identifier": {"system": f"{codes.LOCAL_ID}/export", "value": inputs.report_id},
        "type": "collection",
        "timestamp": iso(inputs.made_at),
        "entry": [{"fullUrl": f"urn:uuid:{r['id']}", "resource": r} for r in resources],
    }
    validate(bundle)
    return bundle


def model_of(resource_type: str):
    """The fhir.resources R4B model class of a resource type (R4B is R4 for every resource used here)."""
    module = importlib.import_module(f"fhir.resources.R4B.{resource_type.lower()}")
    return getattr(module, resource_type)


def validate(bundle: dict) -> None:
    """Every entry, then the Bundle, through fhir.resources; raises InvalidFhir naming the resource."""
    from pydantic import ValidationError

    urls = [e["fullUrl"] for e in bundle["entry"]]
    if len(set(urls)) != len(urls):
        twice = sorted({u for u in urls if urls.count(u) > 1})
        raise InvalidFhir(f"the Bundle holds {len(twice)} fullUrl(s) twice, e.g. {twice[0]}")
    for entry in bundle["entry"]:
        resource = entry["resource"]
        try:
            model_of(resource["resourceType"]).model_validate(resource)
        except ValidationError as exc:
            raise InvalidFhir(f"{resource['resourceType']}/{resource['id']} is not valid FHIR: {exc}") from exc
    try:
        model_of("Bundle").model_validate(bundle)
    except ValidationError as exc:
        raise InvalidFhir(f"the Bundle is not valid FHIR: {exc}") from exc
