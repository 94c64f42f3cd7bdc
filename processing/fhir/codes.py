"""The code systems and codes the FHIR export writes; each is listed with its source in docs/fhir.md.

Only codes checked in the HL7 Skin Wound Assessment IG, the FHIR R4 specification, DICOM's anatomic-region list
or other published value sets are used. Where none was found (total %TBSA burned, surface perimeter, the
photogrammetry method, burnedge's own depth categories and chart regions), the code is burnedge's own, under
LOCAL: an identifier, not a page that resolves.
"""

from __future__ import annotations

from schemas.burn_chart import BurnDepth, LundBrowderRegion
from schemas.patient import EncounterMode, Sex

LOINC = "http://loinc.org"
SNOMED = "http://snomed.info/sct"
UCUM = "http://unitsofmeasure.org"
LOCAL = "https://burnedge.org/fhir/CodeSystem"
"""Base of burnedge's own code systems (e.g. LOCAL + "/observation")."""
LOCAL_OBSERVATION = f"{LOCAL}/observation"
LOCAL_METHOD = f"{LOCAL}/method"
LOCAL_DEPTH = f"{LOCAL}/burn-depth"
LOCAL_REGION = f"{LOCAL}/lund-browder-region"
LOCAL_ID = "https://burnedge.org/fhir/NamingSystem"
"""Base of burnedge's identifier systems (record ids, medical record numbers as the clinic keys them)."""

WOUND_IG = "http://hl7.org/fhir/us/lower-extremity-skin-wound-assessment"
WOUND_SIZE_PROFILE = f"{WOUND_IG}/StructureDefinition/WoundSize"
WOUND_IG_TYPES = f"{WOUND_IG}/wound-observation-type"
"""The IG's local code system; it holds `woundvolume` until LOINC has a code for wound volume."""

ACT_CODE = "http://terminology.hl7.org/CodeSystem/v3-ActCode"
OBSERVATION_CATEGORY = "http://terminology.hl7.org/CodeSystem/observation-category"
CONDITION_CLINICAL = "http://terminology.hl7.org/CodeSystem/condition-clinical"
CONDITION_VERIFICATION = "http://terminology.hl7.org/CodeSystem/condition-ver-status"
CONDITION_CATEGORY = "http://terminology.hl7.org/CodeSystem/condition-category"
PROVENANCE_AGENT = "http://terminology.hl7.org/CodeSystem/provenance-participant-type"
MEDIA_TYPE = "http://terminology.hl7.org/CodeSystem/media-type"
ALLERGY_CLINICAL = "http://terminology.hl7.org/CodeSystem/allergyintolerance-clinical"
ALLERGY_VERIFICATION = "http://terminology.hl7.org/CodeSystem/allergyintolerance-verification"

WOUND_SIZE = (LOINC, "72287-6", "Wound size panel")
WOUND_AREA = (LOINC, "89260-4", "Area of wound")
WOUND_DEPTH = (LOINC, "39127-6", "Depth of Wound")
WOUND_VOLUME = (WOUND_IG_TYPES, "woundvolume", "Volume of Wound")
WOUND_PERIMETER = (LOCAL_OBSERVATION, "wound-perimeter", "Length of the wound's edge on the skin surface")
BODY_SURFACE_AREA = (LOINC, "8277-6", "Body surface area")
BODY_WEIGHT = (LOINC, "29463-7", "Body weight")
BODY_HEIGHT = (LOINC, "8302-2", "Body height")
TBSA_BURNED = (LOCAL_OBSERVATION, "tbsa-burned", "Total body surface area burned, Lund-Browder (superficial excluded)")
TBSA_PARTIAL = (LOCAL_OBSERVATION, "tbsa-partial-thickness", "Partial-thickness burn, share of body surface")
TBSA_FULL = (LOCAL_OBSERVATION, "tbsa-full-thickness", "Full-thickness burn, share of body surface")
PHOTOGRAMMETRY = (LOCAL_METHOD, "photogrammetry-3d", "3D surface from photographs (structure from motion)")
BURN = (SNOMED, "125666000", "Burn (disorder)")
NO_KNOWN_ALLERGY = (SNOMED, "716186003", "No known allergy")
"""As the International Patient Summary IG's "No known allergies" example AllergyIntolerance codes it."""
TETANUS_HISTORY = (LOCAL_OBSERVATION, "tetanus-immunisation-history", "Tetanus immunisation history, as recorded")

DEPTH_SNOMED: dict[BurnDepth, tuple[str, str, str]] = {
    BurnDepth.superficial: (SNOMED, "403190006", "Epidermal burn of skin"),
    BurnDepth.superficial_partial: (SNOMED, "403191005", "Partial thickness burn"),
    BurnDepth.deep_partial: (SNOMED, "403191005", "Partial thickness burn"),
    BurnDepth.full_thickness: (SNOMED, "403192003", "Full thickness burn"),
}
"""The clinician's depth category as a SNOMED CT disorder. No checked disorder code separates superficial from
deep partial thickness, so both map to partial thickness; burnedge's own code (LOCAL_DEPTH) keeps the split."""

DEPTH_TEXT = {
    BurnDepth.superficial: "Superficial (epidermal) burn",
    BurnDepth.superficial_partial: "Superficial partial-thickness burn",
    BurnDepth.deep_partial: "Deep partial-thickness burn",
    BurnDepth.full_thickness: "Full-thickness burn",
}

SITE_SNOMED = {
    "head": ("69536005", "Head"),
    "neck": ("45048000", "Neck"),
    "trunk": ("22943007", "Trunk"),
    "buttock": ("46862004", "Buttock structure"),
    "genitalia": ("71934003", "Genital structure"),
    "upper_arm": ("40983000", "Upper arm"),
    "lower_arm": ("14975008", "Forearm"),
    "hand": ("85562004", "Hand"),
    "thigh": ("68367000", "Thigh"),
    "lower_leg": ("30021000", "Lower leg"),
    "foot": ("56459004", "Foot"),
}
"""Body structures by the part of a Lund-Browder region's name before its side and face."""

LATERALITY = {"left": ("7771000", "Left"), "right": ("24028007", "Right")}

ENCOUNTER_CLASS = {
    EncounterMode.emergency: (ACT_CODE, "EMER", "emergency"),
    EncounterMode.consultation: (ACT_CODE, "AMB", "ambulatory"),
}

GENDER = {Sex.female: "female", Sex.male: "male", Sex.other: "other", Sex.unknown: "unknown"}


def coding(code: tuple[str, str, str]) -> dict:
    system, value, display = code
    return {"system": system, "code": value, "display": display}


def concept(*codes: tuple[str, str, str], text: str | None = None) -> dict:
    out: dict = {"coding": [coding(c) for c in codes]}
    if text:
        out["text"] = text
    return out


def region_parts(region: LundBrowderRegion) -> tuple[str, str | None, str | None]:
    """(body part, side or None, face or None) of a chart region, e.g. ('lower_arm', 'right', 'anterior')."""
    words = region.value.split("_")
    side = next((w for w in words if w in LATERALITY), None)
    face = words[-1] if words[-1] in ("anterior", "posterior", "palmar", "dorsal", "plantar") else None
    part = "_".join(w for w in words if w not in (side, face))
    return part, side, face


def body_site(region: LundBrowderRegion) -> dict:
    """The region as a CodeableConcept: SNOMED CT body structure (its side and face in the text) and the
    chart's own region code, which keeps both."""
    part, side, face = region_parts(region)
    words = [w for w in (side, part.replace("_", " ").replace("lower arm", "forearm"), face and f"({face})") if w]
    codes = [(SNOMED, *SITE_SNOMED[part]), (LOCAL_REGION, region.value, " ".join(words))]
    return concept(*codes, text=" ".join(words))
